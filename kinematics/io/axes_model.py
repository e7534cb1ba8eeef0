"""Zero-configuration axes descriptions (Wen's Robotics I lecture notes) -> URDF.

In the zero configuration every joint frame is aligned with the base frame, so a chain is
read off in base coordinates: per joint its type, its axis ``h_i`` and the link vector
``p_{i-1,i}`` from frame i-1's origin to frame i's (for a prismatic joint, its value at
``q_i = 0``), and the tool offset ``p_nT`` (and orientation ``R_nT``). Then

    R_0T(q) = R_01(q_1) R_12(q_2) ... R_{n-1,n}(q_n) R_nT
    p_0T(q) = p_01 + R_01 p_12 + ... + R_{0,n-1} p_{n-1,n} + R_0n p_nT

with ``R_{i-1,i} = rot(h_i, q_i)`` for a revolute joint, and ``R_{i-1,i} = I``,
``p_{i-1,i} = p_{i-1,i}(0) + q_i h_i`` for a prismatic one. JSON / YAML shape (``POST
/models/axes``), Wen's SCARA (RRRP)::

    {"name": "wen_scara",
     "joints": [{"type": "R", "h": [0, 0, 1], "p": [0, 0, 0]},
                {"type": "R", "h": [0, 0, 1], "p": [0, 0.4, 0]},
                {"type": "R", "h": [0, 0, 1], "p": [0, 0.3, 0]},
                {"type": "P", "h": [0, 0, 1], "p": [0, 0, 0.1]}],
     "p_nT": [0, 0, 0]}

``angles`` applies to revolute limits and an ``R_nT`` given as ``{rpy}``. The URDF
(:func:`axes_to_urdf`, the layout of :mod:`kinematics.io.serial`) is this formula: joint i's
origin is ``p_{i-1,i}`` (no rotation), its axis ``h_i``; ``tool`` is ``(R_nT, p_nT)``.

Wen's SCARA with q1 = pi/2: ``p_04 = R_01 (l1 y + l2 y + l3 z) = (-l1 - l2, 0, l3)``:

>>> import math
>>> from kinematics.engine.poe import compile_model
>>> scara = axes_from_dict({"joints": [{"type": "R", "h": [0, 0, 1]}, {"type": "R", "h": [0, 0, 1], "p": [0, 0.4, 0]},
...     {"type": "R", "h": [0, 0, 1], "p": [0, 0.3, 0]}, {"type": "P", "h": [0, 0, 1], "p": [0, 0, 0.1]}]})
>>> compile_model(model_from_axes(scara)).fk(np.array([[math.pi / 2, 0, 0, 0]]), ["tool"])[0, 0, :3, 3].round(12) + 0.0
array([-0.7,  0. ,  0.1])
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ..errors import AxesError
from ..model.robot import RobotModel
from . import serial
from .urdf import DEFAULT_MAX_LINKS, parse_urdf

_KEYS = {"name", "angles", "joints", "p_nT", "R_nT"}
_JOINT_KEYS = {"type", "h", "p", "name", "limits"}
DEFAULT_ROBOT_NAME = "axes_robot"


@dataclass(frozen=True, eq=False)
class AxesJoint:
    """One joint: type, unit axis ``h`` and link vector ``p`` (= ``p_{i-1,i}`` at q = 0), base coordinates."""

    name: str
    type: str
    h: np.ndarray
    p: np.ndarray
    limits: tuple[float, float] | None = None


@dataclass(frozen=True, eq=False)
class AxesDescription:
    """A validated zero-configuration description."""

    name: str
    joints: tuple[AxesJoint, ...]
    p_nT: np.ndarray
    R_nT: np.ndarray
    angles: str = "radians"

    @property
    def dof(self) -> int:
        return len(self.joints)


def axes_from_dict(d: Mapping[str, Any]) -> AxesDescription:
    """Validate a description (the shape above); :class:`~kinematics.errors.AxesError` names the field."""
    d = serial.fields(d, _KEYS, AxesError, "an axes description")
    angles, scale = serial.angle_unit(d, AxesError)
    out = []
    for i, raw in enumerate(serial.joint_list(d, AxesError)):
        where = f"joints[{i}]"
        raw = serial.fields(raw, _JOINT_KEYS, AxesError, "a joint", where)
        for key in ("type", "h"):
            if key not in raw:
                raise AxesError(f"{where}.{key}: missing")
        jtype = serial.joint_type(raw["type"], f"{where}.type", AxesError)
        h = serial.unit_vector(raw["h"], f"{where}.h", AxesError)
        p = serial.vector(raw.get("p", [0, 0, 0]), 3, f"{where}.p", AxesError)
        jname = serial.name(raw.get("name", f"joint_{i + 1}"), f"{where}.name", AxesError)
        out.append(AxesJoint(jname, jtype, h, p, serial.joint_limits(raw, jtype, where, scale, AxesError)))
    serial.check_names([j.name for j in out], AxesError)
    p_nT = serial.vector(d.get("p_nT", [0, 0, 0]), 3, "p_nT", AxesError)
    R_nT = serial.rotation(d["R_nT"], "R_nT", scale, AxesError) if "R_nT" in d else np.eye(3)
    name = serial.name(d.get("name", DEFAULT_ROBOT_NAME), "name", AxesError)
    return AxesDescription(name, tuple(out), p_nT, R_nT, angles)


def axes_to_dict(desc: AxesDescription) -> dict:
    """The description in the shape :func:`axes_from_dict` reads (radians, every field explicit):
    the canonical form the service stores and hashes."""
    joints = [serial.joint_row(j, type=j.type, h=serial.plain_list(j.h), p=serial.plain_list(j.p), name=j.name)
              for j in desc.joints]
    return {"name": desc.name, "angles": "radians", "joints": joints, "p_nT": serial.plain_list(desc.p_nT),
            "R_nT": serial.plain_list(desc.R_nT)}


def axes_to_urdf(desc: AxesDescription) -> str:
    """URDF text of the description (the module docstring says how)."""
    joints = [serial.ChainJoint(j.name, j.type, j.p, j.h, j.limits) for j in desc.joints]
    tool = np.eye(4)
    tool[:3, :3] = desc.R_nT
    tool[:3, 3] = desc.p_nT
    return serial.serial_chain_urdf(
        desc.name, joints, tool,
        f"generated by kinematics.io.axes_model from zero-configuration axes ({desc.dof} joints); link_i is "
        "frame i (origin p_{i-1,i} from frame i-1, aligned with the base at q = 0), tool is (R_nT, p_nT)")


def model_from_axes(desc: AxesDescription, *, max_links: int = DEFAULT_MAX_LINKS) -> RobotModel:
    """The robot model of an axes description: its URDF parsed."""
    return parse_urdf(axes_to_urdf(desc), max_links=max_links)


def load_axes(path) -> AxesDescription:
    """Read a description from a ``.yaml``/``.yml``/``.json`` file (errors name the file)."""
    return serial.load_description(path, axes_from_dict, AxesError, "axes description")
