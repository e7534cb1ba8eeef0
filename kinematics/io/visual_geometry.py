"""Visual geometry: the URDF's ``<visual>`` elements of every link, for drawing the robot as it looks.

A link's visuals are a tuple of :class:`VisualElement` (one per ``<visual>`` element, document
order), each placed in the link frame by ``origin`` (``T_link_visual``, 4x4):

* primitives: ``box`` (``size = (x, y, z)``, full edge lengths), ``cylinder`` (``(radius,
  length)``, axis ``z``, centred), ``sphere`` (``(radius,)``);
* meshes (``scale = (sx, sy, sz)``), with ``mesh`` = the index of its bytes in
  :func:`visual_mesh` when the mesh may be read, else None (and :attr:`VisualGeometry.warnings`
  says why). What may be read is decided exactly as for collision meshes
  (:func:`kinematics.io.collision_geometry.resolve_mesh`): catalogue models from the installed
  packages (a ``package://`` name resolved inside them, a regular file), uploaded archives from
  the archive's own mesh members; a plain uploaded URDF's meshes never (nothing is opened).

``color`` is the URDF material's ``rgba`` (inline ``<color>``, or a robot-level ``<material>``
of that name), or None (a mesh then keeps its own materials).

>>> from kinematics.io.urdf import parse_urdf
>>> m = parse_urdf('''<robot name="r"><material name="red"><color rgba="1 0 0 1"/></material>
...   <link name="a"><visual><origin xyz="0 0 0.5"/><geometry><box size="1 2 3"/></geometry>
...   <material name="red"/></visual>
...   <visual><geometry><mesh filename="/etc/passwd.stl"/></geometry></visual></link></robot>''')
>>> g = visual_geometry(m)
>>> [(v.kind, v.size, v.color, v.mesh) for v in g.visuals["a"]]
[('box', (1.0, 2.0, 3.0), (1.0, 0.0, 0.0, 1.0), None), ('mesh', (), None, None)]
>>> g.meshes, g.warnings[0]
(0, "link 'a': mesh '/etc/passwd.stl' not opened (a plain URDF's meshes are never read; upload an archive with the mesh inside)")
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np

from ..errors import UnknownMeshError, URDFError
from ..model.robot import RobotModel
from .collision_geometry import MAX_MESH_BYTES, attribute_numbers, geometry_elements, model_meshes, resolve_mesh
from .urdf import read_xml

#: the media type of each mesh format served
MESH_MEDIA_TYPES = {"stl": "model/stl", "obj": "model/obj", "dae": "model/vnd.collada+xml"}


@dataclass(frozen=True, eq=False)
class VisualElement:
    """One ``<visual>`` element: ``kind`` (box | cylinder | sphere | mesh), ``origin``
    (``T_link_visual``, 4x4), ``size`` (primitives, see the module doc), ``scale`` (meshes),
    ``color`` (rgba in [0, 1], or None), for a mesh its ``source`` (the file name the URDF wrote),
    ``format`` (stl, obj, dae) and ``mesh`` (its index for :func:`visual_mesh`, None when it is
    not read)."""

    kind: str
    origin: np.ndarray
    size: tuple[float, ...] = ()
    scale: tuple[float, ...] = (1.0, 1.0, 1.0)
    color: tuple[float, ...] | None = None
    source: str | None = None
    format: str | None = None
    mesh: int | None = None
    path: Path | None = field(default=None, repr=False)
    data: bytes | None = field(default=None, repr=False)


@dataclass(frozen=True, eq=False)
class VisualGeometry:
    """Per link (``model.links`` order, every link) its visual elements; ``meshes`` the number of
    readable meshes (indices ``0 .. meshes - 1``); ``warnings`` what is not drawn and why."""

    visuals: Mapping[str, tuple[VisualElement, ...]]
    meshes: int = 0
    warnings: tuple[str, ...] = ()
    source: str = "none"

    def mesh_element(self, index: int) -> VisualElement:
        for elements in self.visuals.values():
            for v in elements:
                if v.mesh == index:
                    return v
        raise UnknownMeshError(f"mesh {index!r}: the model serves meshes 0 .. {self.meshes - 1}"
                               if self.meshes else f"mesh {index!r}: the model serves no mesh")


def _materials(root) -> dict[str, tuple[float, ...]]:
    out = {}
    for mat in root.findall("material"):
        color = _color(mat)
        if mat.get("name") and color is not None:
            out[mat.get("name")] = color
    return out


def _color(mat) -> tuple[float, ...] | None:
    c = mat.find("color") if mat is not None else None
    if c is None:
        return None
    rgba = attribute_numbers(c.get("rgba"), 4, (1.0, 1.0, 1.0, 1.0), "<color rgba>")
    return tuple(min(max(x, 0.0), 1.0) for x in rgba)


def visual_geometry(model: RobotModel) -> VisualGeometry:
    """The visual elements of ``model`` (see the module doc). Never raises for a bad element: it
    is skipped and named in ``warnings``. Opens no file (catalogue meshes are only resolved)."""
    source = model_meshes(model)
    try:
        root = read_xml(model.urdf.encode("utf-8"))
    except URDFError:
        return VisualGeometry({link: () for link in model.links},
                              warnings=("the model's URDF text could not be re-read for its visuals",))
    try:
        named = _materials(root)
    except (ValueError, TypeError):
        named = {}
    per_link: dict[str, list[VisualElement]] = {}
    warnings: list[str] = []
    count = 0
    for lname, el, kind, origin, size, filename, scale in geometry_elements(
            root, model.links, "visual", ("box", "cylinder", "sphere"), "is not drawn", warnings, max_scale=1e3):
        mat = el.find("material")
        try:
            color = _color(mat)
        except (ValueError, TypeError) as exc:
            warnings.append(f"link {lname!r}: <visual> skipped ({exc})")
            continue
        if color is None and mat is not None:
            color = named.get(mat.get("name") or "")
        if size is not None:
            per_link.setdefault(lname, []).append(VisualElement(kind, origin, size, color=color))
            continue
        try:
            path, data, fmt = resolve_mesh(source, filename)
        except LookupError as why:
            warnings.append(f"link {lname!r}: mesh {filename!r} not opened ({why})")
            per_link.setdefault(lname, []).append(VisualElement("mesh", origin, scale=scale, color=color,
                                                                source=filename))
            continue
        per_link.setdefault(lname, []).append(VisualElement("mesh", origin, scale=scale, color=color,
                                                            source=filename, format=fmt, mesh=count,
                                                            path=path, data=data))
        count += 1
    visuals = {name: tuple(per_link.get(name, ())) for name in model.links}
    return VisualGeometry(visuals, count, tuple(warnings), source.name)


def visual_mesh(model: RobotModel, index: int | str) -> tuple[bytes, str]:
    """The bytes and format (stl, obj, dae) of visual mesh ``index`` of ``model`` (the ``mesh`` of
    a :class:`VisualElement`; a decimal string is read as the number). Raises
    :class:`~kinematics.errors.UnknownMeshError` for an index the model does not serve --
    anything but a decimal in range, and every index of a plain upload, which serves none.
    A catalogue mesh is read from the file :func:`visual_geometry` resolved (inside the installed
    packages, re-checked to be a regular file of at most :data:`MAX_MESH_BYTES`); an archive's
    from the bytes the registry keeps.

    >>> from kinematics.io import default_catalogue
    >>> data, fmt = visual_mesh(default_catalogue().get("ur5"), "0")
    >>> fmt, data[:5] == b"<?xml"
    ('dae', True)
    """
    if isinstance(index, str):
        if not (index.isascii() and index.isdigit() and len(index) <= 6):
            raise UnknownMeshError(f"mesh {index!r}: give the index of a visual mesh (0, 1, ...)")
        index = int(index)
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
        raise UnknownMeshError(f"mesh {index!r}: give the index of a visual mesh (0, 1, ...)")
    element = visual_geometry(model).mesh_element(int(index))
    if element.data is not None:
        return element.data, element.format
    path = element.path
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_MESH_BYTES + 1)
    except OSError:
        raise UnknownMeshError(f"mesh {index}: {element.source!r} cannot be read") from None
    if len(data) > MAX_MESH_BYTES:
        raise UnknownMeshError(f"mesh {index}: {element.source!r} is larger than {MAX_MESH_BYTES} bytes")
    return data, element.format
