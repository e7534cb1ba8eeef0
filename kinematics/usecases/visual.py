"""The robot as it looks: the visual elements of a model's links and the bytes of its visual meshes.

What may be read is decided by :mod:`kinematics.io.visual_geometry` (as for collision meshes:
catalogue models from the installed packages, uploaded archives from their own members, a plain
upload's meshes never).

>>> from kinematics.io import default_catalogue
>>> ur5 = default_catalogue().get("ur5")
>>> g = visual_geometry(ur5)
>>> g.meshes > 0, g.visuals["base_link"][0].kind, g.visuals["base_link"][0].format
(True, 'mesh', 'dae')
"""

from __future__ import annotations

from ..io.visual_geometry import MESH_MEDIA_TYPES, VisualElement, VisualGeometry
from ..io.visual_geometry import visual_geometry as _visual_geometry
from ..io.visual_geometry import visual_mesh as _visual_mesh
from ..model.robot import RobotModel
from .query import Query

__all__ = ["MESH_MEDIA_TYPES", "VisualElement", "VisualGeometry", "visual_geometry", "visual_mesh"]


def _robot(model: Query | RobotModel) -> RobotModel:
    return model.robot if isinstance(model, Query) else model


def visual_geometry(model: Query | RobotModel) -> VisualGeometry:
    """Per link its visual elements (primitives, meshes with the index of their bytes when they
    may be read), and what is not drawn and why."""
    return _visual_geometry(_robot(model))


def visual_mesh(model: Query | RobotModel, index: int | str) -> tuple[bytes, str, str]:
    """``(bytes, format, media_type)`` of visual mesh ``index``; :class:`~kinematics.errors.UnknownMeshError`
    for an index the model does not serve."""
    data, fmt = _visual_mesh(_robot(model), index)
    return data, fmt, MESH_MEDIA_TYPES[fmt]
