"""What the PoE and zero-configuration-axes readers share: reading fields (numbers, vectors,
names, limits, poses) with errors that name the field, reading files, and writing the URDF
of a serial chain whose joint frames keep the base's orientation.

The URDF (:func:`serial_chain_urdf`) has the root link ``base``, one link ``link_i`` per joint
(the child of joint i), and the leaf link ``tool`` on the fixed joint ``tool_joint``. Joint i
has ``origin`` = a translation only (``rpy = 0``) and its axis in base coordinates, so at
q = 0 every joint frame is aligned with the base (Wen's "zero configuration"); every link gets
primitive visuals (a cylinder on the joint axis, a segment to the next origin).
"""

from __future__ import annotations

import contextlib
import json
import math
from dataclasses import dataclass
from typing import Any, Iterator, Mapping
from xml.sax.saxutils import quoteattr

import numpy as np

from ..errors import DHError, KinematicsError
from ..spatial.rotations import matrix_to_rpy_exact
from ..tolerances import MAX_ABS_COORDINATE, RIGID_TOLERANCE
from . import dh_table as dh
from .text_files import fields, read_description_file  # noqa: F401 - fields: the descriptions read theirs with it

#: joint types of a serial description (continuous: a revolute joint without limits)
JOINT_TYPES = ("revolute", "continuous", "prismatic")
_TYPE_ALIASES = {"revolute": "revolute", "r": "revolute", "continuous": "continuous", "prismatic": "prismatic",
                 "p": "prismatic"}
#: how far an axis may be from unit length before it is refused (it is normalised otherwise)
UNIT_TOLERANCE = RIGID_TOLERANCE
#: most joints of a description
MAX_JOINTS = dh.MAX_DH_ROWS
#: largest description file read (bytes)
MAX_FILE_BYTES = dh.MAX_TABLE_BYTES
#: names of the generated links and fixed joint (not usable as joint names)
RESERVED_NAMES = ("base", "tool", "tool_joint")


@contextlib.contextmanager
def errors_as(cls: type[KinematicsError]) -> Iterator[None]:
    """Re-raise the DH helpers' :class:`DHError` as ``cls`` (same message, naming the field)."""
    try:
        yield
    except DHError as exc:
        raise cls(str(exc)) from None


def number(value: Any, where: str, cls: type[KinematicsError]) -> float:
    with errors_as(cls):
        return dh._number(value, where)


def vector(value: Any, n: int, where: str, cls: type[KinematicsError]) -> np.ndarray:
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise cls(f"{where}: expected {n} numbers, got {value!r}"[:300])
    return np.array([number(v, f"{where}[{k}]", cls) for k, v in enumerate(value)])


def unit_vector(value: Any, where: str, cls: type[KinematicsError]) -> np.ndarray:
    v = vector(value, 3, where, cls)
    norm = float(np.linalg.norm(v))
    if abs(norm - 1.0) > UNIT_TOLERANCE:
        raise cls(f"{where}: {v.tolist()} is not a unit vector (norm {norm:.6g})")
    return v / norm


def name(value: Any, where: str, cls: type[KinematicsError]) -> str:
    with errors_as(cls):
        return dh._name(value, where)


def limits(value: Any, where: str, scale: float, cls: type[KinematicsError]) -> tuple[float, float] | None:
    with errors_as(cls):
        return dh._limits(value, where, scale)


def rigid(value: Any, where: str, angle_scale: float, cls: type[KinematicsError]) -> np.ndarray:
    """A 4x4 rigid transform from a nested list or ``{xyz, rpy}``."""
    with errors_as(cls):
        return np.array(dh._rigid(value, where, angle_scale))


def rotation(value: Any, where: str, angle_scale: float, cls: type[KinematicsError]) -> np.ndarray:
    """A rotation from a 3x3 nested list or ``{rpy}``."""
    if isinstance(value, Mapping):
        unknown = set(value) - {"rpy"}
        if unknown:
            raise cls(f"{where}: unknown key(s) {sorted(unknown)}; expected a 3x3 matrix or {{rpy}}")
        return rigid({"rpy": value.get("rpy", [0, 0, 0])}, where, angle_scale, cls)[:3, :3]
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise cls(f"{where}: expected a 3x3 matrix (3 rows of 3 numbers) or {{rpy}}")
    rows = [vector(row, 3, f"{where}[{i}]", cls).tolist() + [0.0] for i, row in enumerate(value)]
    return rigid(rows + [[0, 0, 0, 1]], where, 1.0, cls)[:3, :3]


def joint_limits(raw: Mapping[str, Any], jtype: str, where: str, scale: float,
                 cls: type[KinematicsError]) -> tuple[float, float] | None:
    """A joint's ``limits`` (revolute ones in the description's angle unit, ``scale`` to radians), None
    without them; a continuous joint has none."""
    if "limits" not in raw:
        return None
    if jtype == "continuous":
        raise cls(f"{where}.limits: a continuous joint has no limits")
    return limits(raw["limits"], f"{where}.limits", scale if jtype != "prismatic" else 1.0, cls)


def joint_row(joint, **row: Any) -> dict:
    """A joint's canonical dict: ``row`` and its ``limits`` (when it has them)."""
    if joint.limits is not None:
        row["limits"] = [plain(joint.limits[0]), plain(joint.limits[1])]
    return row


def load_description(path, from_dict, cls: type[KinematicsError], what: str):
    """``from_dict`` of a ``.yaml``/``.yml``/``.json`` file's mapping (errors name the file)."""
    data = load_mapping(path, cls, what)
    try:
        return from_dict(data)
    except cls as exc:
        raise cls(f"{path}: {exc}") from None


def joint_type(value: Any, where: str, cls: type[KinematicsError]) -> str:
    if not isinstance(value, str) or value.lower() not in _TYPE_ALIASES:
        raise cls(f"{where}: {value!r} is not one of {list(JOINT_TYPES)} (or R, P)")
    return _TYPE_ALIASES[value.lower()]


def angle_unit(d: Mapping[str, Any], cls: type[KinematicsError]) -> tuple[str, float]:
    angles = d.get("angles", "radians")
    if not isinstance(angles, str) or angles.lower() not in dh.ANGLE_UNITS:
        raise cls(f"angles: {angles!r} is not one of {list(dh.ANGLE_UNITS)}")
    angles = angles.lower()
    return angles, (math.pi / 180.0 if angles == "degrees" else 1.0)


def joint_list(d: Mapping[str, Any], cls: type[KinematicsError]) -> list:
    joints = d.get("joints")
    if joints is None:
        raise cls("joints: missing (a list of joints)")
    if not isinstance(joints, (list, tuple)):
        raise cls(f"joints: expected a list of joints, got {type(joints).__name__}")
    if not joints:
        raise cls("joints: a chain needs at least one joint")
    if len(joints) > MAX_JOINTS:
        raise cls(f"joints: {len(joints)} joints; at most {MAX_JOINTS} are allowed")
    return list(joints)


def check_names(names: list[str], cls: type[KinematicsError]) -> None:
    seen: dict[str, int] = {}
    links = {f"link_{i}" for i in range(1, len(names) + 1)}
    for i, jname in enumerate(names):
        if jname in seen:
            raise cls(f"joints[{i}].name: {jname!r} is also the name of joints[{seen[jname]}]")
        if jname in RESERVED_NAMES or jname in links:
            raise cls(f"joints[{i}].name: {jname!r} is reserved for a link or fixed joint of the generated URDF")
        seen[jname] = i


def load_mapping(path, cls: type[KinematicsError], what: str) -> dict:
    """A ``.yaml``/``.yml``/``.json`` file's mapping (errors name the file)."""
    text, suffix = read_description_file(path, cls, what)
    try:
        if suffix == ".json":
            data = json.loads(text)
        else:
            import yaml

            data = yaml.safe_load(text)
    except Exception as exc:  # noqa: BLE001 - json/yaml raise many types
        raise cls(f"{path}: not valid {'JSON' if suffix == '.json' else 'YAML'}: {exc}") from None
    if not isinstance(data, Mapping):
        raise cls(f"{path}: a {what} must be a mapping (JSON object), got {type(data).__name__}")
    return dict(data)


def plain(x: float) -> float | int:
    """A JSON-friendly number: integral values as int, -0.0 as 0."""
    x = float(x) + 0.0
    return int(x) if x.is_integer() and abs(x) < 2**53 else x


def plain_list(a) -> list:
    return [plain_list(v) for v in a] if np.ndim(a) > 1 else [plain(v) for v in np.asarray(a).ravel()]


# ---------------------------------------------------------------------- URDF
@dataclass(frozen=True)
class ChainJoint:
    """A joint of :func:`serial_chain_urdf`: its origin ``xyz`` in the parent link (no rotation),
    its unit ``axis`` in base coordinates, type, name and limits (None: the DH defaults)."""

    name: str
    type: str
    xyz: np.ndarray
    axis: np.ndarray
    limits: tuple[float, float] | None = None


_fmt = dh._fmt


def _align_z(d: np.ndarray) -> np.ndarray:
    """A rotation taking z to the unit vector ``d``."""
    z = np.array([0.0, 0.0, 1.0])
    v, c = np.cross(z, d), float(z @ d)
    if 1.0 + c < 1e-9:  # d = -z (to rounding): a half turn about x
        return np.diag([1.0, -1.0, -1.0])
    K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + K + K @ K * (1.0 / (1.0 + c))


def _cylinder(start: np.ndarray, direction: np.ndarray, length: float, radius: float, material: str,
              centred: bool = False) -> str:
    R = _align_z(direction)
    mid = start if centred else start + direction * length / 2
    r, p, y = matrix_to_rpy_exact(R)
    xyz = " ".join(_fmt(v) for v in mid)
    return (f'<visual><origin xyz="{xyz}" rpy="{_fmt(r)} {_fmt(p)} {_fmt(y)}"/><geometry>'
            f'<cylinder radius="{_fmt(radius)}" length="{_fmt(length)}"/></geometry><material name="{material}"/></visual>')


def serial_chain_urdf(robot: str, joints: list[ChainJoint], tool: np.ndarray, comment: str) -> str:
    """URDF text of a serial chain (see the module docstring); ``tool`` is ``T_link_n_tool``."""
    lengths = [float(np.linalg.norm(j.xyz)) for j in joints] + [float(np.linalg.norm(tool[:3, 3]))]
    scale = max(lengths) if max(lengths) > dh.VISUAL_MIN_LENGTH else dh.VISUAL_DEFAULT_SCALE
    rj, lj, rl = dh.VISUAL_JOINT_RADIUS * scale, dh.VISUAL_JOINT_LENGTH * scale, dh.VISUAL_LINK_RADIUS * scale
    names = ["base"] + [f"link_{i}" for i in range(1, len(joints) + 1)] + ["tool"]
    visuals: dict[str, list[str]] = {n: [] for n in names}
    visuals["base"].append(
        f'<visual><origin xyz="0 0 {_fmt(-0.05 * scale)}" rpy="0 0 0"/><geometry><box size="{_fmt(0.6 * scale)} '
        f'{_fmt(0.6 * scale)} {_fmt(0.1 * scale)}"/></geometry><material name="dh_base"/></visual>')
    lines = []
    for i, j in enumerate(joints):
        parent, child = names[i], names[i + 1]
        length = float(np.linalg.norm(j.xyz))
        if length > dh.VISUAL_MIN_LENGTH:  # the link from the parent's origin to this joint
            visuals[parent].append(_cylinder(np.zeros(3), j.xyz / length, length, rl, "dh_link"))
        visuals[child].append(_cylinder(np.zeros(3), j.axis, lj, rj, "dh_joint", centred=True))
        axis = " ".join(_fmt(v) for v in j.axis)
        limit = ""
        if j.type != "continuous":
            lo, hi = j.limits if j.limits is not None else (
                dh.DEFAULT_PRISMATIC_LIMITS if j.type == "prismatic" else dh.DEFAULT_REVOLUTE_LIMITS)
            limit = f'<limit lower="{_fmt(lo)}" upper="{_fmt(hi)}" effort="{_fmt(dh.DEFAULT_EFFORT)}" ' \
                    f'velocity="{_fmt(dh.DEFAULT_VELOCITY)}"/>'
        else:
            limit = f'<limit effort="{_fmt(dh.DEFAULT_EFFORT)}" velocity="{_fmt(dh.DEFAULT_VELOCITY)}"/>'
        xyz = " ".join(_fmt(v) for v in j.xyz)
        lines.append(f'  <joint name={quoteattr(j.name)} type="{j.type}"><parent link="{parent}"/><child link="{child}"/>'
                     f'<origin xyz="{xyz}" rpy="0 0 0"/><axis xyz="{axis}"/>{limit}</joint>')
    p = tool[:3, 3]
    if float(np.linalg.norm(p)) > dh.VISUAL_MIN_LENGTH:
        visuals[names[-2]].append(_cylinder(np.zeros(3), p / np.linalg.norm(p), float(np.linalg.norm(p)), rl, "dh_link"))
    visuals["tool"].append(
        f'<visual><origin xyz="0 0 0" rpy="0 0 0"/><geometry><box size="{_fmt(0.08 * scale)} {_fmt(0.08 * scale)} '
        f'{_fmt(0.08 * scale)}"/></geometry><material name="dh_tool"/></visual>')
    r, pch, y = matrix_to_rpy_exact(tool[:3, :3])
    lines.append(f'  <joint name="tool_joint" type="fixed"><parent link="{names[-2]}"/><child link="tool"/>'
                 f'<origin xyz="{" ".join(_fmt(v) for v in p)}" rpy="{_fmt(r)} {_fmt(pch)} {_fmt(y)}"/></joint>')
    out = [
        '<?xml version="1.0"?>',
        f"<!-- {comment} -->",
        f"<robot name={quoteattr(robot)}>",
        '  <material name="dh_base"><color rgba="0.3 0.3 0.3 1"/></material>',
        '  <material name="dh_joint"><color rgba="0.2 0.45 0.8 1"/></material>',
        '  <material name="dh_link"><color rgba="0.75 0.75 0.75 1"/></material>',
        '  <material name="dh_tool"><color rgba="0.9 0.5 0.1 1"/></material>',
    ]
    for n in names:
        out.append(f'  <link name="{n}">{"".join(visuals[n])}</link>')
    out += lines
    out.append("</robot>")
    return "\n".join(out) + "\n"


def check_coordinates(v: np.ndarray, where: str, cls: type[KinematicsError]) -> None:
    if not np.all(np.abs(v) <= MAX_ABS_COORDINATE):
        raise cls(f"{where}: beyond +-{MAX_ABS_COORDINATE:g}")
