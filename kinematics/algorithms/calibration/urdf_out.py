"""The calibrated model as URDF: the nominal document with corrected joint origins.

Each calibrated joint's ``<origin>`` becomes ``origin · D_j · exp([ξ_j] ε_j)``: the origin
correction ``D_j`` and the zero offset ``ε_j`` folded in (a rotation of the origin about the
joint's axis for a revolute joint, a translation along it for a prismatic one), which is
exact: the joint's motion commutes with its own exponential. Everything else of the document
(links, meshes, limits, other joints) is kept as it was, so the calibrated model loads in any
URDF reader, Pinocchio's included, and gives the calibrated FK.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from ...io.urdf import read_xml
from ...model.robot import RobotModel
from ...spatial.rotations import matrix_to_rpy_exact


def _fmt(v: float) -> str:
    return repr(float(v)) if v != 0 else "0"


def corrected_urdf(model: RobotModel, corrections: dict[str, np.ndarray], name: str | None = None) -> str:
    """The model's URDF text with ``origin_j <- origin_j @ corrections[j]`` (4, 4) for the named joints;
    ``name`` renames the robot.

    >>> from kinematics.io.urdf import parse_urdf
    >>> text = ('<robot name="r"><link name="a"/><link name="b"/><joint name="j" type="revolute">'
    ...         '<parent link="a"/><child link="b"/><origin xyz="1 0 0"/><axis xyz="0 0 1"/>'
    ...         '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>')
    >>> T = np.eye(4); T[:3, 3] = [0.0, 0.5, 0.0]
    >>> parse_urdf(corrected_urdf(parse_urdf(text), {"j": T})).joints[0].origin[:3, 3].tolist()
    [1.0, 0.5, 0.0]
    """
    root = read_xml(model.urdf.encode() if isinstance(model.urdf, str) else model.urdf)
    joint_map = model.joint_map
    for el in root.findall("joint"):
        jname = el.get("name")
        if jname not in corrections:
            continue
        T = joint_map[jname].origin @ corrections[jname]
        origin = el.find("origin")
        if origin is None:
            origin = ET.SubElement(el, "origin")
        r, p, y = matrix_to_rpy_exact(T[:3, :3])
        origin.set("xyz", " ".join(_fmt(v) for v in T[:3, 3]))
        origin.set("rpy", f"{_fmt(r)} {_fmt(p)} {_fmt(y)}")
    if name:
        root.set("name", name)
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode")
