"""Denavit-Hartenberg tables: the table model, its FK, and DH -> URDF.

Conventions (``docs/design.md``, "Denavit-Hartenberg"). Per row: ``a``, ``alpha``,
``d``, ``theta``, a joint type (revolute or prismatic), a name and optional limits. The
column of the joint variable holds its value at q = 0: ``theta = q + theta_row``
(revolute) or ``d = q + d_row`` (prismatic).

- standard (distal; Spong; De Luca's Robotics 1 slides)::

      A_i = Rot_z(theta_i) Trans_z(d_i) Trans_x(a_i) Rot_x(alpha_i)

- modified (proximal; Craig), row i holds ``a_{i-1}``, ``alpha_{i-1}``::

      A_i = Rot_x(alpha_{i-1}) Trans_x(a_{i-1}) Rot_z(theta_i) Trans_z(d_i)

- ``T_world_tool(q) = base . A_1(q_1) ... A_n(q_n) . tool`` with ``base = T_world_frame0``
  and ``tool = T_frameN_tool``.

Angles are stored in radians and lengths in metres; ``angles: degrees`` in a table file
applies to ``alpha``, ``theta`` and revolute limits (and to ``rpy`` of a base/tool given as
``{xyz, rpy}``).

The generated URDF (:func:`table_to_urdf`) has these links and joints (names are fixed;
the moving joints carry the table's names, default ``joint_1 .. joint_n``):

======================  ==============================================================
link                    frame
======================  ==============================================================
``world``               the root: the world frame
``frame_0``             DH frame 0 (``T_world_frame0 = base``), fixed joint ``base_joint``
``frame_i`` (i = 1..n)  DH frame i: ``T_world_frame_i = base A_1 ... A_i``
``motion_i``            standard DH only: frame i-1 moved by joint i
                        (``base A_1 ... A_{i-1} Rot_z(theta_i) Trans_z(d_i)``); the fixed
                        joint ``frame_i_joint`` carries ``Trans_x(a_i) Rot_x(alpha_i)``
``tool``                the tool frame, the only leaf (fixed joint ``tool_joint``)
======================  ==============================================================

Standard DH needs the helper link ``motion_i``: the motion of joint i comes before the
constant part of ``A_i``, and a URDF joint applies its origin before its motion. In the
modified convention one row is one joint (origin ``Rot_x Trans_x Rot_z(theta) Trans_z(d)``).

URDF requires limits: a row without limits gets :data:`DEFAULT_REVOLUTE_LIMITS` or
:data:`DEFAULT_PRISMATIC_LIMITS`, and every joint gets :data:`DEFAULT_EFFORT` and
:data:`DEFAULT_VELOCITY`.

The product of a table's matrices and URDF -> DH live in :mod:`kinematics.algorithms.dh`.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping
from xml.sax.saxutils import quoteattr

import numpy as np

from ..errors import DHError
from ..model.robot import RobotModel, frozen_array
from ..spatial.rotations import matrix_to_rpy_exact, rpy_to_matrix
from ..tolerances import MAX_ABS_COORDINATE, MAX_ABS_JOINT_VALUE, RIGID_TOLERANCE
from .text_files import MAX_FILE_BYTES, fields, read_description_file
from .urdf import DEFAULT_MAX_LINKS, parse_urdf

CONVENTIONS = ("standard", "modified")
ANGLE_UNITS = ("radians", "degrees")
JOINT_TYPES = ("revolute", "prismatic")
#: accepted spellings of the joint types
_TYPE_ALIASES = {"revolute": "revolute", "r": "revolute", "prismatic": "prismatic", "p": "prismatic"}

#: limits written into the URDF when a revolute row has none (radians)
DEFAULT_REVOLUTE_LIMITS = (-math.pi, math.pi)
#: limits written into the URDF when a prismatic row has none (metres)
DEFAULT_PRISMATIC_LIMITS = (-1.0, 1.0)
#: ``<limit effort>`` of every generated joint (N m or N); DH tables carry no dynamics
DEFAULT_EFFORT = 100.0
#: ``<limit velocity>`` of every generated joint (rad/s or m/s)
DEFAULT_VELOCITY = 2.0
#: most rows a table may have
MAX_DH_ROWS = 1000
#: largest table file :func:`load_table` reads (bytes)
MAX_TABLE_BYTES = MAX_FILE_BYTES
#: names of robots and joints: letters, digits and ``_ . - / :``; at most 128 characters
NAME_PATTERN = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.\-/:]{0,127}$")
#: robot name when a table has none
DEFAULT_ROBOT_NAME = "dh_robot"

_ROW_KEYS = {"type", "a", "alpha", "d", "theta", "name", "limits", "offset"}
_TABLE_KEYS = {"name", "convention", "angles", "joints", "base", "tool"}

# Visual geometry of generated URDFs, as fractions of the table's largest length
VISUAL_JOINT_RADIUS = 0.06
VISUAL_JOINT_LENGTH = 0.25
VISUAL_LINK_RADIUS = 0.025
#: lengths below this (m) get no visual segment
VISUAL_MIN_LENGTH = 1e-9
#: characteristic length used when every a and d of a table is zero (m)
VISUAL_DEFAULT_SCALE = 0.2


@dataclass(frozen=True)
class DHRow:
    """One row of a DH table, in SI units (radians, metres).

    ``theta`` (revolute) or ``d`` (prismatic) is the joint variable's value at q = 0.
    ``limits`` are on q (``(lower, upper)``), or ``None`` for the documented defaults.
    For the modified convention ``a`` and ``alpha`` are ``a_{i-1}`` and ``alpha_{i-1}``.
    """

    type: str
    a: float
    alpha: float
    d: float
    theta: float
    name: str
    limits: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        where = f"joint {self.name!r}"
        if self.type not in JOINT_TYPES:
            raise DHError(f"{where}.type: {self.type!r} is not one of {list(JOINT_TYPES)}")
        for key in ("a", "alpha", "d", "theta"):
            if not math.isfinite(getattr(self, key)):
                raise DHError(f"{where}.{key}: {getattr(self, key)!r} is not finite")
            if abs(getattr(self, key)) > MAX_ABS_COORDINATE:  # the URDF it becomes would be refused
                raise DHError(f"{where}.{key}: {getattr(self, key)!r} is beyond +-{MAX_ABS_COORDINATE:g}")
        if self.limits is not None:
            lo, hi = self.limits
            if not (math.isfinite(lo) and math.isfinite(hi)):
                raise DHError(f"{where}.limits: {self.limits!r} are not finite")
            if max(abs(lo), abs(hi)) > MAX_ABS_JOINT_VALUE:
                raise DHError(f"{where}.limits: {self.limits!r} are beyond +-{MAX_ABS_JOINT_VALUE:g}")
            if lo > hi:
                raise DHError(f"{where}.limits: lower limit {lo} is above upper limit {hi}")

    @property
    def urdf_limits(self) -> tuple[float, float]:
        """The limits written into the URDF (the row's, or the default for its type)."""
        if self.limits is not None:
            return self.limits
        return DEFAULT_REVOLUTE_LIMITS if self.type == "revolute" else DEFAULT_PRISMATIC_LIMITS


class TableRows:
    """What a table of one row per moving joint (``rows``, each with a ``name``) tells from its rows:
    the numeric :class:`DHTable` and the symbolic tables of :mod:`kinematics.algorithms.symbolic`."""

    rows: tuple

    @property
    def dof(self) -> int:
        return len(self.rows)

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Names of the moving joints: the order of q."""
        return tuple(r.name for r in self.rows)


@dataclass(frozen=True, eq=False)
class DHTable(TableRows):
    """A validated DH table (immutable). Build one with :func:`table_from_dict`.

    Attributes:
        name: the robot's name.
        convention: ``standard`` or ``modified``.
        rows: the rows, base to tip.
        base: ``T_world_frame0`` (4, 4), read-only.
        tool: ``T_frameN_tool`` (4, 4), read-only.
        angles: the unit the table was written in (``radians``/``degrees``); values are
            stored in radians either way, and :func:`table_to_dict` writes this unit back.
    """

    name: str
    convention: str
    rows: tuple[DHRow, ...]
    base: np.ndarray = field(default_factory=lambda: frozen_array(np.eye(4)))
    tool: np.ndarray = field(default_factory=lambda: frozen_array(np.eye(4)))
    angles: str = "radians"

    def __post_init__(self) -> None:
        if self.convention not in CONVENTIONS:
            raise DHError(f"convention: {self.convention!r} is not one of {list(CONVENTIONS)}")
        if self.angles not in ANGLE_UNITS:
            raise DHError(f"angles: {self.angles!r} is not one of {list(ANGLE_UNITS)}")
        if not self.rows:
            raise DHError("joints: a DH table needs at least one row")
        for key in ("base", "tool"):
            T = np.asarray(getattr(self, key))
            if T.shape != (4, 4) or not np.all(np.isfinite(T)):
                raise DHError(f"{key}: expected a finite 4x4 matrix")
            R = T[:3, :3]
            if (
                np.max(np.abs(R.T @ R - np.eye(3))) > RIGID_TOLERANCE
                or np.linalg.det(R) < 0
                or np.max(np.abs(T[3] - [0, 0, 0, 1])) > RIGID_TOLERANCE
            ):
                raise DHError(f"{key}: not a rigid transform")

    def __repr__(self) -> str:
        return f"DHTable(name={self.name!r}, convention={self.convention!r}, dof={self.dof})"


# --------------------------------------------------------------------------------------
# validation: dict -> DHTable
# --------------------------------------------------------------------------------------


def _number(value: Any, where: str) -> float:
    """A finite float from a JSON/YAML value (numbers, or strings such as YAML's ``1e-3``)."""
    if isinstance(value, bool) or value is None:
        raise DHError(f"{where}: expected a number, got {value!r}")
    if isinstance(value, (int, float, np.integer, np.floating)):
        v = float(value)
    elif isinstance(value, str):
        try:
            v = float(value.strip())
        except ValueError:
            raise DHError(f"{where}: {value!r} is not a number") from None
    else:
        raise DHError(f"{where}: expected a number, got {type(value).__name__}")
    if not math.isfinite(v):
        raise DHError(f"{where}: {value!r} is not finite")
    if abs(v) > MAX_ABS_COORDINATE:  # lengths, angles, limits and transform entries alike
        raise DHError(f"{where}: {value!r} is beyond +-{MAX_ABS_COORDINATE:g}")
    return v


def _name(value: Any, where: str) -> str:
    if not isinstance(value, str) or not NAME_PATTERN.match(value):
        raise DHError(
            f"{where}: {value!r} is not a valid name (letters, digits and _ . - / :, "
            "starting with a letter, digit or _, at most 128 characters)"
        )
    return value


def _rigid(value: Any, where: str, angle_scale: float) -> np.ndarray:
    """A 4x4 rigid transform from a nested list, or from ``{xyz: [..], rpy: [..]}``."""
    if isinstance(value, Mapping):
        unknown = set(value) - {"xyz", "rpy"}
        if unknown:
            raise DHError(f"{where}: unknown key(s) {sorted(unknown)}; expected a 4x4 matrix or {{xyz, rpy}}")
        xyz = value.get("xyz", [0.0, 0.0, 0.0])
        rpy = value.get("rpy", [0.0, 0.0, 0.0])
        for key, vec in (("xyz", xyz), ("rpy", rpy)):
            if not isinstance(vec, (list, tuple)) or len(vec) != 3:
                raise DHError(f"{where}.{key}: expected 3 numbers, got {vec!r}")
        p = [_number(v, f"{where}.xyz[{k}]") for k, v in enumerate(xyz)]
        r = [_number(v, f"{where}.rpy[{k}]") * angle_scale for k, v in enumerate(rpy)]
        T = np.eye(4)
        T[:3, :3] = rpy_to_matrix(r)
        T[:3, 3] = p
        return frozen_array(T)
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) != 4:
        raise DHError(f"{where}: expected a 4x4 matrix (4 rows of 4 numbers) or {{xyz, rpy}}")
    rows = []
    for i, row in enumerate(value):
        if not isinstance(row, (list, tuple)) or len(row) != 4:
            raise DHError(f"{where}[{i}]: expected a row of 4 numbers, got {row!r}")
        rows.append([_number(v, f"{where}[{i}][{k}]") for k, v in enumerate(row)])
    T = np.array(rows)
    if np.max(np.abs(T[3] - [0.0, 0.0, 0.0, 1.0])) > RIGID_TOLERANCE:
        raise DHError(f"{where}: not a rigid transform: the last row must be [0, 0, 0, 1], got {rows[3]}")
    R = T[:3, :3]
    ortho = float(np.max(np.abs(R.T @ R - np.eye(3))))
    if ortho > RIGID_TOLERANCE:
        raise DHError(
            f"{where}: not a rigid transform: the rotation part is not orthonormal "
            f"(max |R^T R - I| = {ortho:.3g}, tolerance {RIGID_TOLERANCE:g})"
        )
    if np.linalg.det(R) < 0:
        raise DHError(f"{where}: not a rigid transform: the rotation part is a reflection (det < 0)")
    U, _, Vt = np.linalg.svd(R)  # the nearest rotation: a table read with 6 decimals stays exact
    out = np.eye(4)
    out[:3, :3] = U @ Vt
    out[:3, 3] = T[:3, 3]
    return frozen_array(out)


def _limits(value: Any, where: str, scale: float) -> tuple[float, float] | None:
    if value is None:
        return None
    if isinstance(value, Mapping):
        unknown = set(value) - {"lower", "upper"}
        if unknown or "lower" not in value or "upper" not in value:
            raise DHError(f"{where}: expected [lower, upper] or {{lower, upper}}, got {value!r}")
        pair = [value["lower"], value["upper"]]
    elif isinstance(value, (list, tuple)) and len(value) == 2:
        pair = list(value)
    else:
        raise DHError(f"{where}: expected [lower, upper], got {value!r}")
    lo = _number(pair[0], f"{where}.lower") * scale
    hi = _number(pair[1], f"{where}.upper") * scale
    if lo > hi:
        raise DHError(f"{where}: lower limit {pair[0]} is above upper limit {pair[1]}")
    return (lo, hi)


def _reserved_names(n: int, convention: str) -> set[str]:
    """Link names and fixed-joint names of the generated URDF (not usable as joint names)."""
    names = {"world", "tool", "base_joint", "tool_joint"} | {f"frame_{i}" for i in range(n + 1)}
    if convention == "standard":
        names |= {f"motion_{i}" for i in range(1, n + 1)} | {f"frame_{i}_joint" for i in range(1, n + 1)}
    return names


#: ``entry(value, where, angle, degrees)``: one table entry (``a``, ``alpha``, ``d``, ``theta``,
#: ``offset``) as the caller keeps it (a float in radians here; a sympy expression for closed forms)
Entry = Callable[[Any, str, bool, bool], Any]


@dataclass(frozen=True)
class TableFields:
    """The validated fields of a table in the JSON shape of ``POST /models/dh``, its entries made
    by an :data:`Entry` (:func:`read_table`): ``rows`` are dicts of ``type``, ``name``, ``limits``
    (radians for revolute joints), ``a``, ``alpha``, ``d``, ``theta`` (offsets added)."""

    name: str
    convention: str
    angles: str
    rows: tuple[dict, ...]
    base: np.ndarray
    tool: np.ndarray


def _numeric_entry(value: Any, where: str, angle: bool, degrees: bool) -> float:
    v = _number(value, where)
    return v * (math.pi / 180.0) if angle and degrees else v


def read_table(d: Mapping[str, Any], entry: Entry = _numeric_entry, *, max_rows: int = MAX_DH_ROWS,
               rows_limit: str | None = None, reserved: bool = True) -> TableFields:
    """Validate the fields of a DH table (see :func:`table_from_dict`), each entry made by
    ``entry``: the one validation of the numeric tables and of the symbolic ones
    (:func:`kinematics.algorithms.symbolic.symbolic_table_from_dict`). ``max_rows`` bounds the
    rows (``rows_limit`` says why in the message); ``reserved`` refuses joint names the
    generated URDF uses for its links and fixed joints."""
    d = fields(d, _TABLE_KEYS, DHError, "a DH table")
    convention = d.get("convention", "standard")
    if not isinstance(convention, str) or convention.lower() not in CONVENTIONS:
        raise DHError(f"convention: {convention!r} is not one of {list(CONVENTIONS)}")
    convention = convention.lower()
    angles = d.get("angles", "radians")
    if not isinstance(angles, str) or angles.lower() not in ANGLE_UNITS:
        raise DHError(f"angles: {angles!r} is not one of {list(ANGLE_UNITS)}")
    angles = angles.lower()
    degrees = angles == "degrees"
    scale = math.pi / 180.0 if degrees else 1.0

    joints = d.get("joints")
    if joints is None:
        raise DHError("joints: missing (a list of rows)")
    if not isinstance(joints, (list, tuple)):
        raise DHError(f"joints: expected a list of rows, got {type(joints).__name__}")
    if not joints:
        raise DHError("joints: a DH table needs at least one row")
    if len(joints) > max_rows:
        raise DHError(f"joints: {len(joints)} rows; {rows_limit or f'at most {max_rows} are allowed'}")
    taken = _reserved_names(len(joints), convention) if reserved else set()
    rows: list[dict] = []
    seen: dict[str, int] = {}
    for i, raw in enumerate(joints):
        where = f"joints[{i}]"
        raw = fields(raw, _ROW_KEYS, DHError, "a row", where)
        jtype = raw.get("type")
        if jtype is None:
            raise DHError(f"{where}.type: missing (revolute or prismatic)")
        if not isinstance(jtype, str) or jtype.lower() not in _TYPE_ALIASES:
            raise DHError(f"{where}.type: {jtype!r} is not one of {list(JOINT_TYPES)} (or R, P)")
        jtype = _TYPE_ALIASES[jtype.lower()]
        values = {}
        for key in ("a", "alpha", "d", "theta"):
            if key not in raw:
                raise DHError(f"{where}.{key}: missing")
            values[key] = entry(raw[key], f"{where}.{key}", key in ("alpha", "theta"), degrees)
        if "offset" in raw:  # added to the joint variable's column
            values["theta" if jtype == "revolute" else "d"] += entry(raw["offset"], f"{where}.offset",
                                                                     jtype == "revolute", degrees)
        jname = _name(raw.get("name", f"joint_{i + 1}"), f"{where}.name")
        if jname in seen:
            raise DHError(f"{where}.name: {jname!r} is also the name of joints[{seen[jname]}]")
        if jname in taken:
            raise DHError(f"{where}.name: {jname!r} is reserved for a link or fixed joint of the generated URDF")
        seen[jname] = i
        limits = _limits(raw.get("limits"), f"{where}.limits", scale if jtype == "revolute" else 1.0)
        rows.append(dict(type=jtype, name=jname, limits=limits, **values))
    name = _name(d.get("name", DEFAULT_ROBOT_NAME), "name")
    base = _rigid(d["base"], "base", scale) if "base" in d else frozen_array(np.eye(4))
    tool = _rigid(d["tool"], "tool", scale) if "tool" in d else frozen_array(np.eye(4))
    return TableFields(name=name, convention=convention, angles=angles, rows=tuple(rows), base=base, tool=tool)


def table_from_dict(d: Mapping[str, Any]) -> DHTable:
    """Validate a table in the JSON shape of ``POST /models/dh`` and build a :class:`DHTable`.

    Keys: ``name``, ``convention`` (``standard``|``modified``, default standard),
    ``angles`` (``radians``|``degrees``, default radians), ``joints`` (rows with ``type``,
    ``a``, ``alpha``, ``d``, ``theta``, optional ``name``, ``limits`` and ``offset``; an
    ``offset`` is added to the joint variable's column), ``base`` and ``tool`` (4x4 or
    ``{xyz, rpy}``). ``None`` values count as absent.

    Raises :class:`~kinematics.errors.DHError` naming the field, e.g.
    ``joints[2].alpha: 'abc' is not a number``.

    >>> t = table_from_dict({"joints": [{"type": "revolute", "a": 1, "alpha": 0, "d": 0, "theta": 0}]})
    >>> (t.convention, t.rows[0].name, t.rows[0].a)
    ('standard', 'joint_1', 1.0)
    """
    f = read_table(d)
    return DHTable(name=f.name, convention=f.convention, rows=tuple(DHRow(**r) for r in f.rows), base=f.base,
                   tool=f.tool, angles=f.angles)


def _plain(x: float) -> float | int:
    """A JSON-friendly number: integral values as int (0 instead of 0.0), -0.0 as 0."""
    x = float(x) + 0.0
    return int(x) if x.is_integer() and abs(x) < 2**53 else x


def table_to_dict(table: DHTable, angles: str | None = None) -> dict:
    """The table in the JSON shape of ``POST /models/dh`` (feed it back to :func:`table_from_dict`).

    ``angles`` (default: the table's own unit) chooses radians or degrees for ``alpha``,
    ``theta`` and revolute limits. ``base`` and ``tool`` are 4x4 nested lists.
    """
    angles = table.angles if angles is None else angles
    if angles not in ANGLE_UNITS:
        raise DHError(f"angles: {angles!r} is not one of {list(ANGLE_UNITS)}")
    to_unit = (lambda v: math.degrees(v)) if angles == "degrees" else (lambda v: v)
    joints = []
    for r in table.rows:
        row = {
            "type": r.type,
            "a": _plain(r.a),
            "alpha": _plain(to_unit(r.alpha)),
            "d": _plain(r.d),
            "theta": _plain(to_unit(r.theta)),
            "name": r.name,
        }
        if r.limits is not None:
            conv = to_unit if r.type == "revolute" else (lambda v: v)
            row["limits"] = [_plain(conv(r.limits[0])), _plain(conv(r.limits[1]))]
        joints.append(row)
    return {
        "name": table.name,
        "convention": table.convention,
        "angles": angles,
        "joints": joints,
        "base": [[_plain(v) for v in row] for row in table.base],
        "tool": [[_plain(v) for v in row] for row in table.tool],
    }


def load_table(path) -> DHTable:
    """Read a table from a ``.yaml``/``.yml``/``.json`` file (raises DHError naming the file)."""
    text, suffix = read_description_file(path, DHError, "DH table")
    return loads_table(text, fmt="json" if suffix == ".json" else "yaml", source=str(path))


def loads_table(text: str, fmt: str = "yaml", source: str = "table") -> DHTable:
    """Parse table text (``fmt`` ``yaml`` or ``json``; YAML also reads JSON)."""
    try:
        if fmt == "json":
            data = json.loads(text)
        else:
            import yaml

            data = yaml.safe_load(text)
    except Exception as exc:  # noqa: BLE001 - json/yaml raise many types
        raise DHError(f"{source}: not valid {fmt.upper()}: {exc}") from None
    try:
        return table_from_dict(data)
    except DHError as exc:
        raise DHError(f"{source}: {exc}") from None


# --------------------------------------------------------------------------------------
# DH -> URDF
# --------------------------------------------------------------------------------------


def _fmt(x: float) -> str:
    """Shortest text that reads back as the same float (so the URDF is exact)."""
    x = float(x) + 0.0
    return repr(x)


def _origin(T: np.ndarray) -> str:
    r, p, y = matrix_to_rpy_exact(T[:3, :3])
    xyz = " ".join(_fmt(v) for v in T[:3, 3])
    return f'<origin xyz="{xyz}" rpy="{_fmt(r)} {_fmt(p)} {_fmt(y)}"/>'


def _rot_x(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def _rot_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def _trans(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def _cylinder_z(radius: float, length: float, z0: float = 0.0, material: str = "dh_joint") -> str:
    """A cylinder along z from ``z0 - length/2`` to ``z0 + length/2``."""
    return (
        f'<visual><origin xyz="0 0 {_fmt(z0)}" rpy="0 0 0"/>'
        f'<geometry><cylinder radius="{_fmt(radius)}" length="{_fmt(length)}"/></geometry>'
        f'<material name="{material}"/></visual>'
    )


def _segment_x(radius: float, length: float) -> str:
    """A cylinder along x from the origin to ``(length, 0, 0)`` (length may be negative)."""
    return (
        f'<visual><origin xyz="{_fmt(length / 2)} 0 0" rpy="0 {_fmt(math.pi / 2)} 0"/>'
        f'<geometry><cylinder radius="{_fmt(radius)}" length="{_fmt(abs(length))}"/></geometry>'
        f'<material name="dh_link"/></visual>'
    )


def _segment_z(radius: float, start: float, end: float) -> str:
    return _cylinder_z(radius, abs(end - start), (start + end) / 2, material="dh_link")


def table_to_urdf(table: DHTable) -> str:
    """URDF text of a DH table (see the module docstring for its links and joints).

    FK of link ``frame_i`` equals ``base A_1 ... A_i`` and FK of ``tool`` equals
    ``base A_1 ... A_n tool`` (to rounding, for both conventions). Joints carry the table's
    names and limits (defaults when absent); every link has primitive visuals: a cylinder
    along each joint axis, a thin cylinder along each ``a`` and ``d`` and to the tool, a box
    on ``world`` and ``tool``, and a small sphere on a link that would otherwise show nothing.
    """
    n = table.dof
    reserved = _reserved_names(n, table.convention)
    seen: set[str] = set()
    for i, r in enumerate(table.rows):  # tables built in code (e.g. from a URDF) skip table_from_dict
        if r.name in reserved:
            raise DHError(f"joints[{i}].name: {r.name!r} is reserved for a link or fixed joint of the generated URDF")
        if r.name in seen:
            raise DHError(f"joints[{i}].name: {r.name!r} is used by another row")
        seen.add(r.name)
    lengths = [abs(r.a) for r in table.rows] + [abs(r.d) for r in table.rows]
    lengths += [float(np.linalg.norm(table.tool[:3, 3]))]
    scale = max(lengths) if max(lengths) > VISUAL_MIN_LENGTH else VISUAL_DEFAULT_SCALE
    rj, lj, rl = VISUAL_JOINT_RADIUS * scale, VISUAL_JOINT_LENGTH * scale, VISUAL_LINK_RADIUS * scale

    visuals: dict[str, list[str]] = {"world": [], "tool": []}
    for i in range(n + 1):
        visuals[f"frame_{i}"] = []
    if table.convention == "standard":
        for i in range(1, n + 1):
            visuals[f"motion_{i}"] = []
    joints: list[str] = []

    def fixed(name: str, parent: str, child: str, T: np.ndarray) -> None:
        joints.append(
            f'  <joint name="{name}" type="fixed"><parent link="{parent}"/><child link="{child}"/>'
            f"{_origin(T)}</joint>"
        )

    def moving(row: DHRow, parent: str, child: str, T: np.ndarray) -> None:
        jtype = "revolute" if row.type == "revolute" else "prismatic"
        lo, hi = row.urdf_limits
        joints.append(
            f"  <joint name={quoteattr(row.name)} type=\"{jtype}\"><parent link=\"{parent}\"/>"
            f'<child link="{child}"/>{_origin(T)}<axis xyz="0 0 1"/>'
            f'<limit lower="{_fmt(lo)}" upper="{_fmt(hi)}" effort="{_fmt(DEFAULT_EFFORT)}" '
            f'velocity="{_fmt(DEFAULT_VELOCITY)}"/></joint>'
        )

    visuals["world"].append(
        f'<visual><origin xyz="0 0 {_fmt(-0.05 * scale)}" rpy="0 0 0"/><geometry>'
        f'<box size="{_fmt(0.6 * scale)} {_fmt(0.6 * scale)} {_fmt(0.1 * scale)}"/></geometry>'
        f'<material name="dh_base"/></visual>'
    )
    fixed("base_joint", "world", "frame_0", table.base)
    for i, row in enumerate(table.rows, start=1):
        prev, cur = f"frame_{i - 1}", f"frame_{i}"
        if table.convention == "standard":
            helper = f"motion_{i}"
            # joint i moves frame i-1 about/along its z: origin Trans_z(d) Rot_z(theta) (they commute)
            moving(row, prev, helper, _trans(z=row.d) @ _rot_z(row.theta))
            fixed(f"frame_{i}_joint", helper, cur, _trans(x=row.a) @ _rot_x(row.alpha))
            visuals[prev].append(_cylinder_z(rj, lj))  # joint i's axis is z of frame i-1
            if abs(row.d) > VISUAL_MIN_LENGTH:
                visuals[prev].append(_segment_z(rl, 0.0, row.d))
            if abs(row.a) > VISUAL_MIN_LENGTH:
                visuals[helper].append(_segment_x(rl, row.a))
        else:
            T = _rot_x(row.alpha) @ _trans(x=row.a) @ _rot_z(row.theta) @ _trans(z=row.d)
            moving(row, prev, cur, T)
            visuals[cur].append(_cylinder_z(rj, lj))  # joint i's axis is z of frame i
            if abs(row.a) > VISUAL_MIN_LENGTH:
                visuals[prev].append(_segment_x(rl, row.a))
            if abs(row.d) > VISUAL_MIN_LENGTH:
                visuals[cur].append(_segment_z(rl, -row.d, 0.0))
    fixed("tool_joint", f"frame_{n}", "tool", table.tool)
    p = table.tool[:3, 3]
    if float(np.linalg.norm(p)) > VISUAL_MIN_LENGTH:  # a segment from frame n to the tool
        axis = p / np.linalg.norm(p)
        R = np.eye(3)
        z = np.array([0.0, 0.0, 1.0])
        v, c = np.cross(z, axis), float(z @ axis)
        if np.linalg.norm(v) > 1e-12:
            K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
            R = np.eye(3) + K + K @ K * (1.0 / (1.0 + c))
        elif c < 0:
            R = np.diag([1.0, -1.0, -1.0])
        T = np.eye(4)
        T[:3, :3] = R
        T[:3, 3] = p / 2
        r_, p_, y_ = matrix_to_rpy_exact(R)
        mid = " ".join(_fmt(v) for v in T[:3, 3])
        visuals[f"frame_{n}"].append(
            f'<visual><origin xyz="{mid}" rpy="{_fmt(r_)} {_fmt(p_)} {_fmt(y_)}"/><geometry>'
            f'<cylinder radius="{_fmt(rl)}" length="{_fmt(float(np.linalg.norm(p)))}"/></geometry>'
            f'<material name="dh_link"/></visual>'
        )
    visuals["tool"].append(
        f'<visual><origin xyz="0 0 0" rpy="0 0 0"/><geometry><box size="{_fmt(0.08 * scale)} '
        f'{_fmt(0.08 * scale)} {_fmt(0.08 * scale)}"/></geometry><material name="dh_tool"/></visual>'
    )

    for link, vs in visuals.items():  # every link shows at least its origin
        if not vs:
            vs.append(
                f'<visual><origin xyz="0 0 0" rpy="0 0 0"/><geometry><sphere radius="{_fmt(rl)}"/></geometry>'
                f'<material name="dh_link"/></visual>'
            )

    order = ["world"]
    for i in range(n + 1):
        order.append(f"frame_{i}")
        if table.convention == "standard" and i < n:
            order.append(f"motion_{i + 1}")
    order.append("tool")
    lines = [
        '<?xml version="1.0"?>',
        f"<!-- generated by kinematics.dh from a {table.convention} DH table ({n} rows); "
        "link frame_i is DH frame i, tool is the tool frame -->",
        f"<robot name={quoteattr(table.name)}>",
        '  <material name="dh_base"><color rgba="0.3 0.3 0.3 1"/></material>',
        '  <material name="dh_joint"><color rgba="0.2 0.45 0.8 1"/></material>',
        '  <material name="dh_link"><color rgba="0.75 0.75 0.75 1"/></material>',
        '  <material name="dh_tool"><color rgba="0.9 0.5 0.1 1"/></material>',
    ]
    for link in order:
        body = "".join(visuals[link])
        lines.append(f'  <link name="{link}">{body}</link>' if body else f'  <link name="{link}"/>')
    lines.extend(joints)
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


def model_from_table(table: DHTable, *, max_links: int = DEFAULT_MAX_LINKS) -> RobotModel:
    """The robot model of a DH table: its URDF (:func:`table_to_urdf`) parsed, the one path
    from a table into a model (so a DH model is a URDF model like any other)."""
    return parse_urdf(table_to_urdf(table), max_links=max_links)
