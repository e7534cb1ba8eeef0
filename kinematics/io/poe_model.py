"""Product-of-exponentials descriptions (Lynch & Park, Modern Robotics) -> URDF.

A description gives the home pose ``M`` of the end-effector frame and one screw per joint,
angular part first, either in the space frame (``S``: ``T(q) = exp([S_1] q_1) ... exp([S_n]
q_n) M``) or in the end-effector frame (``B``: ``T(q) = M exp([B_1] q_1) ... exp([B_n] q_n)``;
then ``S_i = Ad_M B_i``). JSON / YAML shape (``POST /models/poe``)::

    {"name": "mr_3r_spatial", "angles": "radians",
     "M": [[0, 0, 1, 0.6], [0, 1, 0, 0], [-1, 0, 0, -0.4], [0, 0, 0, 1]],    # or {xyz, rpy}
     "joints": [{"S": [0, 0, 1, 0, 0, 0], "name": "j1", "limits": [-3, 3]},
                {"S": [0, -1, 0, 0, 0, -0.6], "type": "revolute"},
                {"S": [1, 0, 0, 0, -0.4, 0]}]}

A joint is revolute when ``|w| = 1`` (then its pitch ``w . v`` must be 0: joints are not
helical) and prismatic when ``w = 0`` and ``|v| = 1`` (``type`` may say so, or ``continuous``
for a revolute joint without limits). Every joint uses the same letter (``S`` or ``B``).
``angles`` applies to revolute limits and to ``M``'s ``rpy``.

The URDF (:func:`poe_to_urdf`, the layout of :mod:`kinematics.io.serial`) puts joint i's frame
at q = 0 on its axis at the point nearest the origin, ``r_i = w_i x v_i`` (a prismatic joint's
frame stays where the previous one is), aligned with the space frame; ``tool`` is at ``M``.
So its FK is the product of exponentials above, and ``GET /models/{id}/screws`` gives ``S_i`` back.

The 3R spatial chain of Modern Robotics (Example 4.2): turning joint 2 by pi/2 swings the tool
from ``(L1, 0, -L2)`` to ``(L1 + L2, 0, 0)``:

>>> import math
>>> from kinematics.engine.poe import compile_model
>>> desc = poe_from_dict({"M": [[0, 0, 1, 0.6], [0, 1, 0, 0], [-1, 0, 0, -0.4], [0, 0, 0, 1]],
...     "joints": [{"S": [0, 0, 1, 0, 0, 0]}, {"S": [0, -1, 0, 0, 0, -0.6]}, {"S": [1, 0, 0, 0, -0.4, 0]}]})
>>> compile_model(model_from_poe(desc)).fk(np.array([[0, math.pi / 2, 0]]), ["tool"])[0, 0, :3, 3].round(12) + 0.0
array([1., 0., 0.])
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ..errors import PoEError
from ..model.robot import RobotModel
from ..spatial.rotations import skew
from ..tolerances import AXIS_EPS, RIGID_TOLERANCE
from . import serial
from .urdf import DEFAULT_MAX_LINKS, parse_urdf

FRAMES = ("space", "body")
_KEYS = {"name", "angles", "M", "joints"}
_JOINT_KEYS = {"S", "B", "type", "name", "limits"}
DEFAULT_ROBOT_NAME = "poe_robot"


@dataclass(frozen=True, eq=False)
class PoEJoint:
    """One joint: its space screw ``S = (w, v)`` (angular first), type, name and limits."""

    name: str
    type: str  # revolute | continuous | prismatic
    S: np.ndarray
    limits: tuple[float, float] | None = None


@dataclass(frozen=True, eq=False)
class PoEDescription:
    """A validated PoE description: ``M`` (4x4) and the joints' **space** screws (body screws
    given in the description are converted, ``frame`` records which were given)."""

    name: str
    M: np.ndarray
    joints: tuple[PoEJoint, ...]
    frame: str = "space"
    angles: str = "radians"

    @property
    def dof(self) -> int:
        return len(self.joints)

    @property
    def S(self) -> np.ndarray:
        """The space screws (n, 6), angular first."""
        return np.array([j.S for j in self.joints]).reshape(-1, 6)

    @property
    def B(self) -> np.ndarray:
        """The body screws (n, 6): ``B_i = Ad_{M^-1} S_i``."""
        return (adjoint(np.linalg.inv(self.M)) @ self.S.T).T


def adjoint(T: np.ndarray) -> np.ndarray:
    """The 6x6 adjoint of a pose for twists with the angular part first: ``[[R, 0], [[p] R, R]]``."""
    R, p = T[:3, :3], T[:3, 3]
    Ad = np.zeros((6, 6))
    Ad[:3, :3] = R
    Ad[3:, 3:] = R
    Ad[3:, :3] = skew(p) @ R
    return Ad


def poe_from_dict(d: Mapping[str, Any]) -> PoEDescription:
    """Validate a PoE description (the shape above); :class:`~kinematics.errors.PoEError` names the field."""
    d = serial.fields(d, _KEYS, PoEError, "a PoE description")
    angles, scale = serial.angle_unit(d, PoEError)
    if "M" not in d:
        raise PoEError("M: missing (the end-effector pose at q = 0: a 4x4 matrix or {xyz, rpy})")
    M = serial.rigid(d["M"], "M", scale, PoEError)
    joints = serial.joint_list(d, PoEError)
    letters = set()
    out = []
    for i, raw in enumerate(joints):
        where = f"joints[{i}]"
        raw = serial.fields(raw, _JOINT_KEYS, PoEError, "a joint", where)
        given = [k for k in ("S", "B") if k in raw]
        if len(given) != 1:
            raise PoEError(f"{where}: give its screw as S (space frame) or B (body frame), exactly one")
        letter = given[0]
        letters.add(letter)
        if len(letters) > 1:
            raise PoEError(f"{where}.{letter}: every joint must use the same frame (S for all, or B for all)")
        screw = serial.vector(raw[letter], 6, f"{where}.{letter}", PoEError)
        w, v = screw[:3], screw[3:]
        nw, nv = float(np.linalg.norm(w)), float(np.linalg.norm(v))
        if abs(nw - 1.0) <= RIGID_TOLERANCE:
            kind = "revolute"
            w = w / nw
            pitch = float(w @ v)
            if abs(pitch) > RIGID_TOLERANCE * max(1.0, nv):
                raise PoEError(f"{where}.{letter}: pitch w.v = {pitch:.6g}; a revolute joint's screw has w.v = 0 "
                               "(v = -w x r for a point r on the axis)")
            v = v - pitch * w
        elif nw <= AXIS_EPS:
            if abs(nv - 1.0) > RIGID_TOLERANCE:
                raise PoEError(f"{where}.{letter}: a prismatic joint's screw (w = 0) needs a unit v; |v| = {nv:.6g}")
            kind = "prismatic"
            v = v / nv
            w = np.zeros(3)
        else:
            raise PoEError(f"{where}.{letter}: the angular part w must be a unit vector (revolute) or zero "
                           f"(prismatic); |w| = {nw:.6g}")
        jtype = kind
        if "type" in raw:
            jtype = serial.joint_type(raw["type"], f"{where}.type", PoEError)
            if (jtype == "prismatic") != (kind == "prismatic"):
                raise PoEError(f"{where}.type: {jtype!r}, but {letter} is the screw of a {kind} joint")
        jname = serial.name(raw.get("name", f"joint_{i + 1}"), f"{where}.name", PoEError)
        lim = serial.joint_limits(raw, jtype, where, scale, PoEError)
        screw = np.concatenate([w, v])
        if letter == "B":
            screw = adjoint(M) @ screw
        out.append(PoEJoint(jname, jtype, screw, lim))
    serial.check_names([j.name for j in out], PoEError)
    name = serial.name(d.get("name", DEFAULT_ROBOT_NAME), "name", PoEError)
    return PoEDescription(name, M, tuple(out), "body" if letters == {"B"} else "space", angles)


def poe_to_dict(desc: PoEDescription) -> dict:
    """The description in the shape :func:`poe_from_dict` reads: space screws, radians, M as 4x4
    (the canonical form the service stores and hashes)."""
    joints = [serial.joint_row(j, S=serial.plain_list(j.S), type=j.type, name=j.name) for j in desc.joints]
    return {"name": desc.name, "angles": "radians", "M": serial.plain_list(desc.M), "joints": joints}


def poe_to_urdf(desc: PoEDescription) -> str:
    """URDF text of the description (the module docstring says how)."""
    joints, previous = [], np.zeros(3)
    for j in desc.joints:
        w, v = j.S[:3], j.S[3:]
        if j.type == "prismatic":
            point, axis = previous, v
        else:
            point, axis = np.cross(w, v), w  # the point of the axis nearest the origin
        serial.check_coordinates(point, f"joint {j.name!r}: the point on the axis", PoEError)
        joints.append(serial.ChainJoint(j.name, j.type, point - previous, axis, j.limits))
        previous = point
    tool = desc.M.copy()
    tool[:3, 3] = desc.M[:3, 3] - previous
    frame = "space-frame screws S_i" if desc.frame == "space" else "body-frame screws B_i (as S_i = Ad_M B_i)"
    return serial.serial_chain_urdf(
        desc.name, joints, tool,
        f"generated by kinematics.io.poe_model from a product of exponentials ({desc.dof} joints, {frame}); "
        "link_i is joint i's frame (on its axis, aligned with the base at q = 0), tool is M")


def model_from_poe(desc: PoEDescription, *, max_links: int = DEFAULT_MAX_LINKS) -> RobotModel:
    """The robot model of a PoE description: its URDF parsed."""
    return parse_urdf(poe_to_urdf(desc), max_links=max_links)


def load_poe(path) -> PoEDescription:
    """Read a description from a ``.yaml``/``.yml``/``.json`` file (errors name the file)."""
    return serial.load_description(path, poe_from_dict, PoEError, "PoE description")
