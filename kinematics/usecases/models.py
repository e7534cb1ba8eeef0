"""Models: loading one (catalogue id, URDF, DH table, xacro, MJCF), model descriptions (DH, PoE,
zero-configuration axes), a model's screws and DH form (the warm-up of the compiled kernels: :mod:`.warm`)."""

from __future__ import annotations

from typing import Any, Sequence

from ..algorithms.dh import urdf_to_dh
from ..engine.poe import require_one_dof
from ..errors import KinematicsError
from ..io.catalogue import default_catalogue
from ..io.dh_table import load_table, model_from_table
from ..io.urdf import load_urdf
from ..model.robot import RobotModel


def load_model(*, model_id: str | None = None, urdf: str | None = None, dh: str | None = None,
               xacro: str | None = None, mjcf: str | None = None, args: dict[str, Any] | None = None,
               package_paths: Sequence[str] = ()) -> RobotModel:
    """The model of a catalogue id, a URDF file, a DH table file, a xacro file or an MJCF file
    (exactly one of them). A xacro file is expanded in a sandboxed process that may read only
    its directory and ``package_paths`` (whose packages ``$(find pkg)`` resolves), with the
    xacro ``args``; meshes are never opened."""
    if sum(x is not None for x in (model_id, urdf, dh, xacro, mjcf)) != 1:
        raise KinematicsError("name exactly one model: a catalogue id, a URDF, DH table, xacro or MJCF file")
    if (args or package_paths) and xacro is None:
        raise KinematicsError("xacro arguments and package paths apply to a xacro file (--xacro) only")
    if model_id is not None:
        return default_catalogue().get(model_id)
    if urdf is not None:
        return load_urdf(urdf)
    if xacro is not None:
        from ..io.xacro import load_xacro

        return load_xacro(xacro, args=args, package_paths=package_paths)
    if mjcf is not None:
        from ..io.mjcf import load_mjcf

        return load_mjcf(mjcf)
    return model_from_table(load_table(dh))


def compiled_models() -> tuple[int, int]:
    """``(compiled, cached)``: how many models this process has compiled to their PoE form so far,
    and how many compiled forms it holds now (one per live model). For monitoring."""
    from ..engine.poe import compiled_counts

    return compiled_counts()


def screws(model: RobotModel):
    """The model's product-of-exponentials parameters (:class:`~kinematics.engine.poe.PoEModel`):
    space screws ``S`` (angular first), axes ``w``, points ``r``, home poses ``M`` (models of
    one-dof joints only: :class:`~kinematics.errors.UnsupportedJointError` otherwise)."""
    return require_one_dof(model, "the product-of-exponentials form (screws)")


def dh_form(model: RobotModel, tip: str | None = None, convention: str = "standard"):
    """The DH table (:class:`~kinematics.io.dh_table.DHTable`) of the chain from the root to
    ``tip``, with base and tool; :class:`NoDHFormError` when the chain has none."""
    require_one_dof(model, "a DH form")
    return urdf_to_dh(model, tip=tip, convention=convention)


def reference_name() -> str:
    """The reference library requests are verified against, with its version (``pinocchio 4.1.0``)."""
    from ..verify.pinocchio import REFERENCE_NAME

    return REFERENCE_NAME


#: the model descriptions the library reads, by kind: (reader of a dict, file reader, canonical dict, model)
def _descriptions():
    from ..io import axes_model, dh_table, poe_model

    return {
        "dh": (dh_table.table_from_dict, dh_table.load_table,
               lambda t: dh_table.table_to_dict(t, angles="radians"), dh_table.model_from_table),
        "poe": (poe_model.poe_from_dict, poe_model.load_poe, poe_model.poe_to_dict, poe_model.model_from_poe),
        "axes": (axes_model.axes_from_dict, axes_model.load_axes, axes_model.axes_to_dict, axes_model.model_from_axes),
    }


DESCRIPTION_KINDS = ("dh", "poe", "axes")


def model_from_description(kind: str, description: Any, *, max_links: int | None = None
                           ) -> tuple[RobotModel, dict[str, Any]]:
    """``(model, canonical dict)`` of a model description: a DH table, a PoE description or a
    zero-configuration axes description (``kind``), given as a dict (the JSON of ``POST /models/<kind>``)
    or a ``.yaml``/``.json`` file path. The canonical dict (radians, every field explicit) reads back
    to the same model."""
    if kind not in DESCRIPTION_KINDS:
        raise KinematicsError(f"kind: {kind!r} is not one of {list(DESCRIPTION_KINDS)}")
    from_dict, load, to_dict, build = _descriptions()[kind]
    spec = from_dict(description) if isinstance(description, dict) else load(description)
    kwargs = {} if max_links is None else {"max_links": max_links}
    return build(spec, **kwargs), to_dict(spec)


def description_urdf(kind: str, description: Any) -> str:
    """The URDF text a description becomes (dict or file path, as :func:`model_from_description`)."""
    return model_from_description(kind, description)[0].urdf
