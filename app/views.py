"""Library objects -> wire dictionaries (no math: poses and measures come from ``kinematics``)."""

from __future__ import annotations

import numpy as np

from kinematics import pose_components
from kinematics.model import Joint

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


def model_info(rec: ModelRecord) -> dict:
    m = rec.model
    return {
        "id": rec.id, "name": rec.name, "source": rec.source, "dof": m.dof, "root": m.root,
        "joint_names": list(m.joint_names), "links": list(m.links), "leaf_links": list(m.leaf_links),
        "joints": [joint_info(j) for j in m.joints], "warnings": list(m.warnings),
        "urdf_sha256": m.content_hash, "created": rec.created, "dh_table": rec.dh_table,
    }


def poses_json(T: np.ndarray, links: list[str], fmt: str, is_batch: bool):
    """``poses`` of an FK answer from T (N, L, 4, 4), in format pose | matrix | compact."""
    N = T.shape[0]
    if fmt == "matrix":
        per_config = [{link: T[n, k] for k, link in enumerate(links)} for n in range(N)]
        return per_config if is_batch else per_config[0]
    comps = pose_components(T)
    position = np.ascontiguousarray(comps["position"])
    quaternion = np.ascontiguousarray(comps["quaternion"])
    if fmt == "compact":
        return {link: {"positions": np.ascontiguousarray(position[:, k]),
                       "quaternions": np.ascontiguousarray(quaternion[:, k])} for k, link in enumerate(links)}
    rpy = np.ascontiguousarray(comps["rpy"])
    quats = quaternion.tolist()
    per_config = []
    for n in range(N):
        qn = quats[n]
        per_config.append({
            link: {"matrix": T[n, k], "position": position[n, k],
                   "quaternion": {"w": qn[k][0], "x": qn[k][1], "y": qn[k][2], "z": qn[k][3]}, "rpy": rpy[n, k]}
            for k, link in enumerate(links)
        })
    return per_config if is_batch else per_config[0]
