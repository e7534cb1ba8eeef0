"""Library objects -> wire dictionaries (no math: poses and measures come from ``kinematics``)."""

from __future__ import annotations

from kinematics.io.floating import with_floating_base
from kinematics.model.robot import Joint
from kinematics.spatial.transforms import pose_components

from .registry import ModelRecord


def joint_info(joint: Joint) -> dict:
    origin = pose_components(joint.origin)
    limits = None
    if joint.limits is not None and joint.type != "continuous":
        lim = joint.limits
        limits = {"lower": lim.lower, "upper": lim.upper, "effort": lim.effort, "velocity": lim.velocity}
    mimic = None
    if joint.mimic is not None:
        mimic = {"joint": joint.mimic.leader, "multiplier": joint.mimic.multiplier, "offset": joint.mimic.offset}
    return {
        "name": joint.name, "type": joint.type, "axis": joint.axis.tolist(), "parent": joint.parent,
        "child": joint.child, "origin": {"xyz": origin["position"].tolist(), "rpy": origin["rpy"].tolist()},
        "limits": limits, "mimic": mimic,
    }


def model_info(rec: ModelRecord, floating_base: bool = False, note: str | None = None) -> dict:
    """The model info (``floating_base``: of the model on a free-flyer root joint); ``note`` says what
    a registration did when it did not create the model."""
    m = with_floating_base(rec.model) if floating_base else rec.model
    info = {
        "id": rec.id, "name": rec.name, "source": rec.source, "dof": m.dof, "nq": m.nq, "nv": m.nv,
        "q_layout": [s.as_dict() for s in m.layout], "floating_base": floating_base, "root": m.root,
        "joint_names": list(m.joint_names), "links": list(m.links), "leaf_links": list(m.leaf_links),
        "joints": [joint_info(j) for j in m.joints], "warnings": list(m.warnings),
        "urdf_sha256": m.content_hash, "created": rec.created, "dh_table": rec.dh_table,
        "description": rec.description, "format": _format(rec), "upload": rec.upload,
    }
    if note is not None:
        info["note"] = note
    return info


def _format(rec: ModelRecord) -> str:
    """What the model was written in: the model's own format (urdf, xacro, mjcf), or the table or
    description it was built from (dh, poe, axes)."""
    if rec.dh_table is not None:
        return "dh"
    if rec.description is not None:
        return rec.source
    return rec.model.format
