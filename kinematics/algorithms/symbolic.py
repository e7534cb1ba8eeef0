"""Closed forms of serial chains with sympy: the factors ``A_i``, ``T(q)``, Jacobians and task
vectors, printed as LaTeX, Python (numpy), C or text.

The only module of the library that imports sympy (import contract ``one-sympy``).

**Chains.** A chain is the path from a model's root to a tip link (URDF joints: origin, then
the motion about or along the axis; fixed joints fold into the next factor), or a DH table
(standard or modified) whose entries may be numbers or expressions of named parameters
(``"a1"``, ``"d4"``, ``"-l2/2"``, ``"pi/2"``; :func:`symbolic_table_from_dict`). Numbers become
exact where they are simple: entries within rounding of 0, +-1/2, +-sqrt(2)/2, +-sqrt(3)/2,
+-1 and angles within rounding of a multiple of pi/12 become those values, decimals of at most
12 significant digits become rationals (``0.425`` -> ``17/40``); anything else stays a
floating-point number, so the closed form is the model's FK to rounding (the UR5's
``rpy="0 1.57079632679 0"`` is *not* pi/2, and its closed form keeps the 5e-12 it differs by).

Frames: for a DH table, frame i is DH frame i and ``T = base A_1 ... A_n tool``. For a URDF
chain, frame 0 is the root link, frame i the child link of the i-th moving joint, ``A_i =
T_frame{i-1}_frame{i}`` (fixed joints before the moving joint included), ``tool`` the fixed
joints after the last one, ``base`` the identity. The joint variables are ``q1 .. qn`` (or the
joint names); a mimic joint contributes ``multiplier * q_leader + offset``.

**Composition.** The rotation is kept as ``R_s Rot(w, Theta) C``: consecutive joints whose axes
stay parallel add their angles (``Theta = q2 + q3 + q4``), a constant rotation about the same
axis folds into ``Theta`` (the Panda's hand: ``q7 - pi/4``), and everything else is expanded;
so ``T`` comes out in the notes' terms (``c_12``, ``s_124``) without trigonometric search.
``simplify=True`` then runs sympy's ``simplify`` on every entry (factoring ``s1 d2 + s1 d3``
into ``s1 (d2 + d3)``); that is the slow part, and :func:`run_with_timeout` bounds it.

The RPR arm of the notes (``003_*``) has ``T3_0 = [[c1 c3, -c1 s3, s1, s1 (d2 + d3)], ...]``:

>>> table = symbolic_table_from_dict({"angles": "degrees", "joints": [
...     {"type": "R", "a": 0, "alpha": 90, "d": "d1", "theta": 0},
...     {"type": "P", "a": 0, "alpha": 0, "d": 0, "theta": 0},
...     {"type": "R", "a": 0, "alpha": 0, "d": "d3", "theta": 0}]})
>>> forms = closed_forms(chain_from_table(table), simplify=True)
>>> forms.T[:3, :]
Matrix([
[cos(q1)*cos(q3), -sin(q3)*cos(q1),  sin(q1),  (d3 + q2)*sin(q1)],
[sin(q1)*cos(q3), -sin(q1)*sin(q3), -cos(q1), -(d3 + q2)*cos(q1)],
[        sin(q3),          cos(q3),        0,                 d1]])
"""

from __future__ import annotations

import decimal
import math
import multiprocessing
import re
import time
import traceback
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import sympy as sp
from sympy.printing.c import C99CodePrinter
from sympy.printing.numpy import NumPyPrinter
from sympy.simplify.fu import TR10i

from ..errors import DHError, KinematicsError, SymbolicError, SymbolicTimeoutError, UnknownLinkError, did_you_mean
from ..io import dh_table as dh
from ..model.robot import RobotModel
from ..tolerances import MAX_ABS_COORDINATE
from .task import PRESETS, TaskRepresentation

FORMATS = ("latex", "python", "c", "text")
WHAT = ("transforms", "jacobian", "task")
#: the Jacobians of a closed form (Pinocchio's meaning; linear rows first)
JACOBIAN_REFERENCES = ("local_world_aligned", "world")
VARIABLE_STYLES = ("q", "names")
#: rotation representations with symbolic task vectors: atan2 forms (Euler angles); the quaternion's
#: qw >= 0 branch (valid where qw > 0); the rotation vector through atan2 (valid for angles below pi)
SYMBOLIC_ROTATIONS = ("rpy", "zyx", "zyz", "quaternion", "rotvec")
#: the rotation vector's closed form switches to its series ``(1/2 + (1 - cos theta)/6) v`` when
#: ``cos theta`` is above this (theta below 1e-4 rad: the series' error is below 1e-18 rad there)
ROTVEC_SERIES_COS = 1 - 5e-9
#: most moving joints on a chain whose closed forms are derived
MAX_SYMBOLIC_JOINTS = 24
#: longest expression accepted in a table entry (characters)
MAX_EXPRESSION_LENGTH = 200
#: a number within this many units in the last place of a simple value is that value
SNAP_ULPS = 4
#: decimals with at most this many significant digits become exact rationals
MAX_DECIMAL_DIGITS = 12
#: terms whose floating-point coefficient is below this are rounding residue and dropped (a term
#: is at most |coefficient| x |q|, so even at |q| = 1e6 this is 1e-14 m)
CHOP = 1e-20
#: entries with fewer operations than this also get their common factors taken out (kept when shorter)
SMALL_ENTRY_OPS = 40
#: time limit of :func:`run_with_timeout` when the caller gives none (seconds)
DEFAULT_TIMEOUT = 60.0

_SPECIAL = ((0.0, sp.Integer(0)), (0.5, sp.Rational(1, 2)), (math.sqrt(2) / 2, sp.sqrt(2) / 2),
            (math.sqrt(3) / 2, sp.sqrt(3) / 2), (1.0, sp.Integer(1)))


# ====================================================================== numbers
def _decimal(x: float) -> sp.Expr | None:
    """The short decimal (at most 12 significant digits) within 2 ulps of ``x``, as a rational."""
    text = f"{x:.{MAX_DECIMAL_DIGITS}g}"
    if abs(float(text) - x) <= 2 * math.ulp(x):
        return sp.Rational(*decimal.Decimal(text).as_integer_ratio())
    return None


def exact_number(x: float) -> sp.Expr:
    """``x`` exact where it is simple (a special value or a short decimal), else a 17-digit Float.

    >>> exact_number(6.123233995736766e-17), exact_number(0.7071067811865476), exact_number(0.425)
    (0, sqrt(2)/2, 17/40)
    """
    x = float(x)
    if not math.isfinite(x):
        raise SymbolicError(f"{x!r} is not finite")
    tol = SNAP_ULPS * math.ulp(1.0) / 2
    for value, expr in _SPECIAL:
        if abs(abs(x) - value) <= tol:
            return expr if x >= 0 else -expr
    short = _decimal(x)
    return short if short is not None else sp.Float(x, 17)


def exact_angle(x: float, degrees: bool = False) -> sp.Expr:
    """An angle in radians, exact when within rounding of a multiple of pi/12 (or, for a table
    written in degrees, of a short decimal number of degrees).

    >>> exact_angle(math.pi / 2), exact_angle(-math.radians(45)), exact_angle(math.radians(33.3), degrees=True)
    (pi/2, -pi/4, 37*pi/200)
    """
    x = float(x)
    if not math.isfinite(x):
        raise SymbolicError(f"{x!r} is not finite")
    k = round(x / (math.pi / 12))
    if abs(x - k * math.pi / 12) <= SNAP_ULPS * math.ulp(max(abs(x), 1.0)):
        return sp.Rational(k, 12) * sp.pi
    if degrees:
        deg = math.degrees(x)
        text = f"{deg:.{MAX_DECIMAL_DIGITS}g}"
        if abs(math.radians(float(text)) - x) <= SNAP_ULPS * math.ulp(max(abs(x), 1.0)):
            return sp.Rational(*decimal.Decimal(text).as_integer_ratio()) * sp.pi / 180
    return exact_number(x)


# ====================================================================== expressions
_TOKEN = re.compile(r"\s*(?:(?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)|(?P<name>[A-Za-z_][A-Za-z0-9_]*)"
                    r"|(?P<op>\*\*|[-+*/^()]))")
_JOINT_VARIABLE = re.compile(r"^q\d+$")
_IDENTIFIER = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
#: largest integer exponent an expression may use
MAX_EXPONENT = 8


def parameter_symbol(name: str, where: str = "name") -> sp.Symbol:
    """The real symbol of a parameter name; refused when it is not an identifier, names a joint
    variable (``q<i>``) or means something else to sympy (``E``, ``I``, ``beta``, ``lambda``, ...)."""
    if not isinstance(name, str) or not _IDENTIFIER.match(name) or len(name) > 64:
        raise SymbolicError(f"{where}: {name!r} is not a parameter name (letters, digits and _, starting with a letter)")
    if _JOINT_VARIABLE.match(name):
        raise SymbolicError(f"{where}: {name!r} is reserved for a joint variable (q1 .. qn)")
    try:
        parsed = sp.sympify(name)  # an identifier only: looks the name up, nothing else
    except (sp.SympifyError, SyntaxError, TypeError, AttributeError):
        parsed = None
    if not (isinstance(parsed, sp.Symbol) and parsed.name == name):
        raise SymbolicError(f"{where}: {name!r} means something else to sympy (a constant or function); "
                            "choose another name")
    return sp.Symbol(name, real=True)


class _Parser:
    """Recursive descent over ``+ - * / ^ ** ( )``, numbers, parameter names and ``pi``."""

    def __init__(self, text: str, where: str):
        self.where = where
        self.tokens: list[tuple[str, str]] = []
        pos = 0
        text = text.strip()
        while pos < len(text):
            m = _TOKEN.match(text, pos)
            if not m or m.end() == pos:
                raise SymbolicError(f"{where}: cannot read {text!r} at {text[pos:pos + 10]!r} (numbers, parameter "
                                    "names, pi, + - * / ^ and parentheses)")
            kind = m.lastgroup
            self.tokens.append((kind, m.group(kind)))
            pos = m.end()
        self.i = 0
        self.depth = 0

    def peek(self) -> tuple[str, str] | None:
        return self.tokens[self.i] if self.i < len(self.tokens) else None

    def take(self) -> tuple[str, str]:
        tok = self.peek()
        if tok is None:
            raise SymbolicError(f"{self.where}: the expression ends too early")
        self.i += 1
        return tok

    def parse(self) -> sp.Expr:
        if not self.tokens:
            raise SymbolicError(f"{self.where}: empty expression")
        e = self.expr()
        if self.peek() is not None:
            raise SymbolicError(f"{self.where}: unexpected {self.peek()[1]!r}")
        return e

    def expr(self) -> sp.Expr:
        e = self.term()
        while self.peek() in (("op", "+"), ("op", "-")):
            op = self.take()[1]
            rhs = self.term()
            e = e + rhs if op == "+" else e - rhs
        return e

    def term(self) -> sp.Expr:
        e = self.unary()
        while self.peek() in (("op", "*"), ("op", "/")):
            op = self.take()[1]
            rhs = self.unary()
            if op == "/":
                if rhs == 0:
                    raise SymbolicError(f"{self.where}: division by zero")
                e = e / rhs
            else:
                e = e * rhs
        return e

    def unary(self) -> sp.Expr:
        if self.peek() in (("op", "+"), ("op", "-")):
            op = self.take()[1]
            e = self.unary()
            return -e if op == "-" else e
        return self.power()

    def power(self) -> sp.Expr:
        base = self.atom()
        if self.peek() in (("op", "^"), ("op", "**")):
            self.take()
            sign = 1
            if self.peek() == ("op", "-"):
                self.take()
                sign = -1
            kind, text = self.take()
            if kind != "num" or not text.isdigit() or int(text) > MAX_EXPONENT:
                raise SymbolicError(f"{self.where}: exponents are integers up to {MAX_EXPONENT}")
            if sign < 0 and base == 0:
                raise SymbolicError(f"{self.where}: division by zero")
            return base ** (sign * int(text))
        return base

    def atom(self) -> sp.Expr:
        kind, text = self.take()
        if kind == "num":
            return sp.Rational(*decimal.Decimal(text).as_integer_ratio())
        if kind == "name":
            if self.peek() == ("op", "("):
                raise SymbolicError(f"{self.where}: functions ({text}(...)) are not allowed in a table entry")
            if text == "pi":
                return sp.pi
            return parameter_symbol(text, self.where)
        if text == "(":
            self.depth += 1
            if self.depth > 20:
                raise SymbolicError(f"{self.where}: parentheses nested too deeply")
            e = self.expr()
            if self.take() != ("op", ")"):
                raise SymbolicError(f"{self.where}: missing ')'")
            self.depth -= 1
            return e
        raise SymbolicError(f"{self.where}: unexpected {text!r}")


def parse_expression(text: str, where: str = "expression") -> sp.Expr:
    """A table entry as an expression: numbers, parameter names, ``pi``, ``+ - * / ^`` and
    parentheses (read by a small parser of its own: nothing is evaluated).

    >>> parse_expression("-l2/2 + 0.1")
    1/10 - l2/2
    """
    if not isinstance(text, str):
        raise SymbolicError(f"{where}: expected a number or an expression, got {type(text).__name__}")
    if len(text) > MAX_EXPRESSION_LENGTH:
        raise SymbolicError(f"{where}: expressions have at most {MAX_EXPRESSION_LENGTH} characters")
    return _Parser(text, where).parse()


# ====================================================================== symbolic DH tables
@dataclass(frozen=True)
class SymbolicDHRow:
    """A DH row whose ``a``, ``alpha``, ``d``, ``theta`` are sympy expressions (angles in radians)."""

    type: str
    a: sp.Expr
    alpha: sp.Expr
    d: sp.Expr
    theta: sp.Expr
    name: str
    limits: tuple[float, float] | None = None


@dataclass(frozen=True, eq=False)
class SymbolicDHTable:
    """A DH table with symbolic entries (:func:`symbolic_table_from_dict`); base and tool are numeric."""

    name: str
    convention: str
    rows: tuple[SymbolicDHRow, ...]
    base: np.ndarray
    tool: np.ndarray
    angles: str = "radians"

    @property
    def dof(self) -> int:
        return len(self.rows)

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(r.name for r in self.rows)

    @property
    def parameters(self) -> tuple[sp.Symbol, ...]:
        syms = set()
        for r in self.rows:
            for e in (r.a, r.alpha, r.d, r.theta):
                syms |= e.free_symbols
        return tuple(sorted(syms, key=lambda s: s.name))


def _entry(value: Any, where: str, angle: bool, degrees: bool) -> sp.Expr:
    if isinstance(value, bool) or value is None:
        raise DHError(f"{where}: expected a number or an expression, got {value!r}")
    number = None
    if isinstance(value, (int, float, np.integer, np.floating)):
        number = value
    elif isinstance(value, str):
        try:
            number = float(value.strip())
        except ValueError:
            number = None
    else:
        raise DHError(f"{where}: expected a number or an expression, got {type(value).__name__}")
    if number is not None:
        v = float(number)
        if not math.isfinite(v) or abs(v) > MAX_ABS_COORDINATE:
            raise DHError(f"{where}: {value!r} is not finite or beyond +-{MAX_ABS_COORDINATE:g}")
        if angle and degrees:
            short = _decimal(v) if v != 0 else sp.Integer(0)
            return (short if short is not None else sp.Float(v, 17)) * sp.pi / 180
        return exact_angle(v) if angle else exact_number(v)
    try:
        expr = parse_expression(value, where)
    except SymbolicError as exc:
        raise DHError(str(exc)) from None
    return expr * sp.pi / 180 if angle and degrees else expr


def symbolic_table_from_dict(d: Mapping[str, Any]) -> SymbolicDHTable:
    """Validate a DH table whose ``a``, ``alpha``, ``d``, ``theta`` (and ``offset``) may be
    expressions of parameters (``"a1"``, ``"-d4"``, ``"pi/2"``); the shape of ``POST /models/dh``.

    Angles: in a table written in ``degrees``, an expression counts in degrees too (``"alpha1"``
    becomes ``pi*alpha1/180``). Base and tool are numeric (4x4 or ``{xyz, rpy}``). The numeric
    path (:func:`kinematics.io.dh_table.table_from_dict`) is unchanged; errors are
    :class:`~kinematics.errors.DHError` naming the field.
    """
    if not isinstance(d, Mapping):
        raise DHError(f"a DH table must be a mapping (JSON object), got {type(d).__name__}")
    d = {k: v for k, v in d.items() if v is not None}
    unknown = set(d) - dh._TABLE_KEYS
    if unknown:
        raise DHError(f"unknown field(s) {sorted(unknown)}; a DH table has {sorted(dh._TABLE_KEYS)}")
    convention = d.get("convention", "standard")
    if not isinstance(convention, str) or convention.lower() not in dh.CONVENTIONS:
        raise DHError(f"convention: {convention!r} is not one of {list(dh.CONVENTIONS)}")
    convention = convention.lower()
    angles = d.get("angles", "radians")
    if not isinstance(angles, str) or angles.lower() not in dh.ANGLE_UNITS:
        raise DHError(f"angles: {angles!r} is not one of {list(dh.ANGLE_UNITS)}")
    angles = angles.lower()
    degrees = angles == "degrees"
    joints = d.get("joints")
    if joints is None:
        raise DHError("joints: missing (a list of rows)")
    if not isinstance(joints, (list, tuple)):
        raise DHError(f"joints: expected a list of rows, got {type(joints).__name__}")
    if not joints:
        raise DHError("joints: a DH table needs at least one row")
    if len(joints) > MAX_SYMBOLIC_JOINTS:
        raise DHError(f"joints: {len(joints)} rows; closed forms are derived for at most {MAX_SYMBOLIC_JOINTS}")
    rows: list[SymbolicDHRow] = []
    seen: dict[str, int] = {}
    for i, raw in enumerate(joints):
        where = f"joints[{i}]"
        if not isinstance(raw, Mapping):
            raise DHError(f"{where}: expected a mapping with type, a, alpha, d, theta")
        raw = {k: v for k, v in raw.items() if v is not None}
        unknown = set(raw) - dh._ROW_KEYS
        if unknown:
            raise DHError(f"{where}: unknown field(s) {sorted(unknown)}; a row has {sorted(dh._ROW_KEYS)}")
        jtype = raw.get("type")
        if jtype is None:
            raise DHError(f"{where}.type: missing (revolute or prismatic)")
        if not isinstance(jtype, str) or jtype.lower() not in dh._TYPE_ALIASES:
            raise DHError(f"{where}.type: {jtype!r} is not one of {list(dh.JOINT_TYPES)} (or R, P)")
        jtype = dh._TYPE_ALIASES[jtype.lower()]
        values = {}
        for key in ("a", "alpha", "d", "theta"):
            if key not in raw:
                raise DHError(f"{where}.{key}: missing")
            values[key] = _entry(raw[key], f"{where}.{key}", key in ("alpha", "theta"), degrees)
        if "offset" in raw:
            off = _entry(raw["offset"], f"{where}.offset", jtype == "revolute", degrees)
            values["theta" if jtype == "revolute" else "d"] += off
        jname = dh._name(raw.get("name", f"joint_{i + 1}"), f"{where}.name")
        if jname in seen:
            raise DHError(f"{where}.name: {jname!r} is also the name of joints[{seen[jname]}]")
        seen[jname] = i
        limits = dh._limits(raw.get("limits"), f"{where}.limits",
                            math.pi / 180 if degrees and jtype == "revolute" else 1.0)
        rows.append(SymbolicDHRow(type=jtype, name=jname, limits=limits, **values))
    name = dh._name(d.get("name", dh.DEFAULT_ROBOT_NAME), "name")
    scale = math.pi / 180 if degrees else 1.0
    base = dh._rigid(d["base"], "base", scale) if "base" in d else np.eye(4)
    tool = dh._rigid(d["tool"], "tool", scale) if "tool" in d else np.eye(4)
    return SymbolicDHTable(name, convention, tuple(rows), np.asarray(base), np.asarray(tool), angles)


# ====================================================================== chains
@dataclass(frozen=True, eq=False)
class Step:
    """One joint of a chain: the constant origin ``[rotation, translation]``, then the motion
    (``revolute``: about ``axis`` by ``value``; ``prismatic``: along ``axis`` by ``value``)."""

    kind: str  # fixed | revolute | prismatic
    rotation: sp.Matrix
    translation: sp.Matrix
    axis: sp.Matrix | None = None
    value: sp.Expr | None = None
    joint: str | None = None


@dataclass(frozen=True, eq=False)
class SymbolicChain:
    """A serial chain ready for :func:`closed_forms`.

    ``variables`` are the joint variables (symbols), ``joints`` the joint each one is (the
    order of q on the chain), ``parameters`` the other symbols. ``factors[i]`` are the steps of
    ``A_{i+1}``; ``base`` and ``tool`` constant steps; ``frames`` the names of frames 1..n.
    """

    name: str
    source: str  # dh-standard | dh-modified | urdf
    variables: tuple[sp.Symbol, ...]
    joints: tuple[str, ...]
    parameters: tuple[sp.Symbol, ...]
    base: tuple[Step, ...]
    factors: tuple[tuple[Step, ...], ...]
    tool: tuple[Step, ...]
    root: str
    tip: str
    frames: tuple[str, ...]

    @property
    def dof(self) -> int:
        return len(self.variables)


def _unit(axis) -> sp.Matrix:
    return sp.Matrix([exact_number(v) for v in axis])


def _rot_x(a: sp.Expr) -> sp.Matrix:
    c, s = sp.cos(a), sp.sin(a)
    return sp.Matrix([[1, 0, 0], [0, c, -s], [0, s, c]])


def _rot_z(a: sp.Expr) -> sp.Matrix:
    c, s = sp.cos(a), sp.sin(a)
    return sp.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])


_Z = sp.Matrix([0, 0, 1])
_ZERO3 = sp.zeros(3, 1)


def _variables(names: Sequence[str], style: str) -> tuple[sp.Symbol, ...]:
    if style not in VARIABLE_STYLES:
        raise SymbolicError(f"variables: {style!r} is not one of {list(VARIABLE_STYLES)}")
    if style == "q":
        return tuple(sp.Symbol(f"q{i + 1}", real=True) for i in range(len(names)))
    out, seen = [], {}
    for name in names:
        ident = re.sub(r"[^A-Za-z0-9_]", "_", name)
        if not ident or ident[0].isdigit():
            ident = "j_" + ident
        if ident in seen:
            raise SymbolicError(f"variables: joints {seen[ident]!r} and {name!r} give the same symbol {ident!r}; "
                                "use variables 'q'")
        try:
            parsed = sp.sympify(ident)
        except (sp.SympifyError, SyntaxError, TypeError, AttributeError):
            parsed = None
        if not (isinstance(parsed, sp.Symbol) and parsed.name == ident):
            raise SymbolicError(f"variables: joint {name!r} cannot be a symbol name ({ident!r} means something else "
                                "to sympy); use variables 'q'")
        seen[ident] = name
        out.append(sp.Symbol(ident, real=True))
    return tuple(out)


def _check_parameters(parameters: Sequence[sp.Symbol], variables: Sequence[sp.Symbol]) -> None:
    clash = {s.name for s in parameters} & {v.name for v in variables}
    if clash:
        raise SymbolicError(f"parameter {sorted(clash)[0]!r} has the name of a joint variable; rename it")


def _const_step(T: np.ndarray) -> Step:
    T = np.asarray(T, dtype=float)
    return Step("fixed", sp.Matrix(3, 3, [exact_number(v) for v in T[:3, :3].ravel()]),
                sp.Matrix([exact_number(v) for v in T[:3, 3]]))


def _is_identity(step: Step) -> bool:
    return step.rotation == sp.eye(3) and step.translation == _ZERO3


def chain_from_table(table, variables: str = "q") -> SymbolicChain:
    """The chain of a DH table (:class:`~kinematics.io.dh_table.DHTable` or :class:`SymbolicDHTable`):
    frame i is DH frame i, ``A_i`` the DH matrix of row i, ``T = base A_1 ... A_n tool``."""
    if len(table.rows) > MAX_SYMBOLIC_JOINTS:
        raise SymbolicError(f"the table has {len(table.rows)} rows; closed forms are derived for at most "
                            f"{MAX_SYMBOLIC_JOINTS}")
    degrees = getattr(table, "angles", "radians") == "degrees"
    qs = _variables(table.joint_names, variables)
    factors = []
    params: set[sp.Symbol] = set()
    for row, q in zip(table.rows, qs):
        if isinstance(row, SymbolicDHRow):
            a, alpha, d, theta = row.a, row.alpha, row.d, row.theta
        else:
            a, d = exact_number(row.a), exact_number(row.d)
            alpha, theta = exact_angle(row.alpha, degrees), exact_angle(row.theta, degrees)
        for e in (a, alpha, d, theta):
            params |= e.free_symbols
        revolute = row.type == "revolute"
        if table.convention == "standard":  # Rot_z(theta) Trans_z(d) Trans_x(a) Rot_x(alpha)
            if revolute:
                steps = (Step("revolute", sp.eye(3), _ZERO3, _Z, q + theta, row.name),
                         Step("fixed", _rot_x(alpha), sp.Matrix([a, 0, d])))
            else:
                steps = (Step("prismatic", _rot_z(theta), _ZERO3, _Z, q + d, row.name),
                         Step("fixed", _rot_x(alpha), sp.Matrix([a, 0, 0])))
        else:  # Rot_x(alpha) Trans_x(a) Rot_z(theta) Trans_z(d)
            if revolute:
                steps = (Step("revolute", _rot_x(alpha), sp.Matrix([a, 0, 0]), _Z, q + theta, row.name),
                         Step("fixed", sp.eye(3), sp.Matrix([0, 0, d])))
            else:
                steps = (Step("prismatic", _rot_x(alpha) * _rot_z(theta), sp.Matrix([a, 0, 0]), _Z, q + d, row.name),)
        factors.append(steps)
    parameters = tuple(sorted(params, key=lambda s: s.name))
    _check_parameters(parameters, qs)
    base = _const_step(table.base)
    tool = _const_step(table.tool)
    n = len(table.rows)
    return SymbolicChain(
        name=table.name, source=f"dh-{table.convention}", variables=qs, joints=tuple(table.joint_names),
        parameters=parameters, base=() if _is_identity(base) else (base,), factors=tuple(factors),
        tool=() if _is_identity(tool) else (tool,), root="world", tip="tool",
        frames=tuple(f"frame_{i}" for i in range(1, n + 1)))


def chain_tip(model: RobotModel, tip: str | None) -> str:
    """``tip``, or the model's only leaf link (a tree needs a tip)."""
    if tip is None:
        if len(model.leaf_links) != 1:
            shown = ", ".join(repr(l) for l in model.leaf_links[:8]) + (" ..." if len(model.leaf_links) > 8 else "")
            raise SymbolicError(f"model {model.name!r} has {len(model.leaf_links)} leaf links ({shown}); "
                                "choose the tip of the chain")
        return model.leaf_links[0]
    if tip != model.root and tip not in model.parent_joint:
        raise UnknownLinkError(f"model {model.name!r} has no link {tip!r}"
                               + did_you_mean(tip, model.links, "link names"))
    return tip


def chain_from_model(model: RobotModel, tip: str | None = None, variables: str = "q") -> SymbolicChain:
    """The chain from ``model.root`` to ``tip`` (default: the only leaf link), from the URDF joints.

    Joint variables: the independent joints that move the chain, in chain order (a mimic
    joint's value is ``multiplier * q_leader + offset``).
    """
    tip = chain_tip(model, tip)
    path = model.path_joints(tip)
    drivers: list[str] = []
    for j in path:
        if j.moving:
            resolved = model.resolve_mimic(j)
            leader = j.name if resolved is None else resolved[0]
            if leader not in drivers:
                drivers.append(leader)
    if not drivers:
        raise SymbolicError(f"the chain from {model.root!r} to {tip!r} has no moving joint")
    if len(drivers) > MAX_SYMBOLIC_JOINTS:
        raise SymbolicError(f"the chain to {tip!r} has {len(drivers)} joint variables; closed forms are derived "
                            f"for at most {MAX_SYMBOLIC_JOINTS}")
    qs = _variables(drivers, variables)
    symbol = dict(zip(drivers, qs))
    factors, current, frames = [], [], []
    for j in path:
        origin = _const_step(j.origin)
        if not j.moving:
            current.append(origin)
            continue
        resolved = model.resolve_mimic(j)
        if resolved is None:
            value = symbol[j.name]
        else:
            leader, mult, off = resolved
            value = exact_number(mult) * symbol[leader] + (exact_angle(off) if j.type != "prismatic" else exact_number(off))
        kind = "prismatic" if j.type == "prismatic" else "revolute"
        current.append(Step(kind, origin.rotation, origin.translation, _unit(j.axis), value, j.name))
        factors.append(tuple(current))
        frames.append(j.child)
        current = []
    return SymbolicChain(
        name=model.name, source="urdf", variables=qs, joints=tuple(drivers), parameters=(), base=(),
        factors=tuple(factors), tool=tuple(current), root=model.root, tip=tip, frames=tuple(frames))


# ====================================================================== composition
def _clean(e: sp.Expr) -> sp.Expr:
    """Expanded, with floating-point numbers that rounding made of simple ones (``1 - 2.4e-23`` is
    ``1.0``) made exact again, and terms with a floating-point coefficient below :data:`CHOP`
    (what is left of cancellations, ``3.6e-29*sin(q1)``) dropped."""
    e = sp.expand(e)
    floats = e.atoms(sp.Float)
    if floats:
        e = sp.expand(e.xreplace({f: exact_number(f) for f in floats}))
        if e.is_Add:
            e = sp.Add(*[t for t in e.args
                         if not (isinstance(c := t.as_coeff_Mul()[0], sp.Float) and abs(c) < CHOP)])
        elif isinstance(c := e.as_coeff_Mul()[0], sp.Float) and abs(c) < CHOP:
            e = sp.Integer(0)
    return e


def _expand(M: sp.Matrix) -> sp.Matrix:
    return M.applyfunc(_clean)


def _rotation(w: sp.Matrix, t: sp.Expr) -> sp.Matrix:
    """Rot(w, t) for an exact unit axis (the plain matrices for the coordinate axes)."""
    c, s = sp.cos(t), sp.sin(t)
    for k in range(3):
        if w[k] in (1, -1) and all(w[i] == 0 for i in range(3) if i != k):
            s_ = s * w[k]
            if k == 0:
                return sp.Matrix([[1, 0, 0], [0, c, -s_], [0, s_, c]])
            if k == 1:
                return sp.Matrix([[c, 0, s_], [0, 1, 0], [-s_, 0, c]])
            return sp.Matrix([[c, -s_, 0], [s_, c, 0], [0, 0, 1]])
    W = sp.Matrix([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    return _expand(sp.eye(3) + s * W + (1 - c) * W * W)


def _same(u: sp.Matrix, v: sp.Matrix) -> bool:
    return all(sp.expand(a - b) == 0 for a, b in zip(u, v))


class _Composer:
    """The running pose ``R_s Rot(w, Theta) C``, ``p`` of a chain (see the module docstring)."""

    def __init__(self):
        self.Rs = sp.eye(3)
        self.w: sp.Matrix | None = None
        self.theta: sp.Expr = sp.Integer(0)
        self.C = sp.eye(3)
        self.p = sp.zeros(3, 1)
        self._R: sp.Matrix | None = sp.eye(3)

    def _fold(self) -> None:
        """A constant rotation about the running axis joins the running angle (when exact)."""
        if self.w is None or self.C == sp.eye(3) or self.C.atoms(sp.Float) or not _same(self.C * self.w, self.w):
            return  # (a rotation with floating-point entries stays as it is: its angle is not exact)
        u = next(sp.Matrix(e) for e in ([1, 0, 0], [0, 1, 0], [0, 0, 1]) if not _same(sp.Matrix(e).cross(self.w), _ZERO3))
        u = u - (u.dot(self.w)) * self.w
        Cu = self.C * u
        beta = sp.atan2(sp.expand(self.w.dot(u.cross(Cu))), sp.expand(u.dot(Cu)))
        if isinstance(beta, sp.atan2) or not (beta / sp.pi).is_Rational:
            return
        self.theta = self.theta + beta
        self.C = sp.eye(3)
        self._R = None

    def rotation(self) -> sp.Matrix:
        if self._R is None:
            self._fold()
            R = self.Rs if self.w is None else self.Rs * _rotation(self.w, self.theta)
            self._R = _expand(R * self.C)
        return self._R

    def origin(self, R: sp.Matrix, t: sp.Matrix) -> None:
        if t != _ZERO3:
            self.p = _expand(self.p + self.rotation() * t)
        if R != sp.eye(3):
            self.C = self.C * R
            self._R = None

    def revolute(self, axis: sp.Matrix, value: sp.Expr) -> sp.Matrix:
        """Turn by ``value`` about ``axis`` (current coordinates); the axis in world coordinates."""
        world = _expand(self.rotation() * axis)
        v = self.C * axis
        if self.w is not None and _same(v, self.w):
            self.theta = self.theta + value
        elif self.w is not None and _same(v, -self.w):
            self.theta = self.theta - value
        else:
            self.Rs = self.rotation()
            self.w, self.theta, self.C = axis, value, sp.eye(3)
        self._R = None
        return world

    def prismatic(self, axis: sp.Matrix, value: sp.Expr) -> sp.Matrix:
        world = _expand(self.rotation() * axis)
        self.p = _expand(self.p + value * world)
        return world

    def step(self, s: Step):
        self.origin(s.rotation, s.translation)
        if s.kind == "revolute":
            return self.revolute(s.axis, s.value)
        if s.kind == "prismatic":
            return self.prismatic(s.axis, s.value)
        return None

    def pose(self) -> sp.Matrix:
        T = sp.eye(4)
        T[:3, :3] = self.rotation()
        T[:3, 3] = self.p
        return T


def _compose(steps: Sequence[Step]) -> sp.Matrix:
    c = _Composer()
    for s in steps:
        c.step(s)
    return c.pose()


def _reduce_squares(e: sp.Expr) -> sp.Expr:
    """``sin(x)^2 -> 1 - cos(x)^2`` (higher powers alike), expanded: products of a chain's
    rotation and position terms cancel to their canonical form."""
    e = sp.expand(e)
    if not e.has(sp.sin):
        return e

    def is_sin_power(x):
        return x.is_Pow and isinstance(x.base, sp.sin) and x.exp.is_Integer and x.exp >= 2

    def reduce(x):
        n = int(x.exp)
        return x.base ** (n % 2) * (1 - sp.cos(x.base.args[0]) ** 2) ** (n // 2)

    for _ in range(4):
        new = sp.expand(e.replace(is_sin_power, reduce))
        if new == e:
            break
        e = new
    return _clean(e)


# ====================================================================== closed forms
@dataclass(eq=False)
class TaskForms:
    """A symbolic task vector ``r(q)`` (m x 1) and its analytic Jacobian ``J_r = dr/dq`` (m x n)."""

    representation: TaskRepresentation
    r: sp.Matrix
    J_r: sp.Matrix
    #: built piece by piece (quaternions, rotation vectors): already tidied, not simplified again
    structured: bool = False


@dataclass(eq=False)
class ClosedForms:
    """The closed forms of a chain (sympy matrices).

    ``A``: the factors (4x4 each); ``base``, ``tool``: constant 4x4; ``frames``: ``T_world_frame_i``
    (i = 1..n); ``T``: ``base A_1 ... A_n tool``; ``jacobians``: 6 x n per reference (linear rows
    first) of the tip; ``task``: :class:`TaskForms` or None; ``seconds``: time taken.
    """

    chain: SymbolicChain
    A: list[sp.Matrix]
    base: sp.Matrix
    tool: sp.Matrix
    frames: list[sp.Matrix]
    T: sp.Matrix
    jacobians: dict[str, sp.Matrix] = field(default_factory=dict)
    task: TaskForms | None = None
    simplified: bool = False
    seconds: float = 0.0


def _atan2(y: sp.Expr, x: sp.Expr) -> sp.Expr:
    """atan2 with ``atan2(sin u, cos u) = u`` (angles up to multiples of 2 pi)."""
    if isinstance(y, sp.sin) and isinstance(x, sp.cos) and y.args[0] == x.args[0]:
        return y.args[0]
    if isinstance(-y, sp.sin) and isinstance(x, sp.cos) and (-y).args[0] == x.args[0]:
        return -x.args[0]
    return sp.atan2(y, x)


def _task_expressions(T: sp.Matrix, rep: TaskRepresentation) -> sp.Matrix:
    R = T[:3, :3]
    values = {"px": T[0, 3], "py": T[1, 3], "pz": T[2, 3]}
    if rep.rotation in ("rpy", "zyx"):
        yaw = _atan2(R[1, 0], R[0, 0])
        pitch = _atan2(-R[2, 0], sp.sqrt(sp.expand(R[2, 1] ** 2 + R[2, 2] ** 2)))
        roll = _atan2(R[2, 1], R[2, 2])
        values.update(roll=roll, pitch=pitch, yaw=yaw, gamma_x=roll, beta_y=pitch, alpha_z=yaw)
    elif rep.rotation == "zyz":
        values.update(phi=_atan2(R[1, 2], R[0, 2]), theta=_atan2(sp.sqrt(sp.expand(R[0, 2] ** 2 + R[1, 2] ** 2)), R[2, 2]),
                      psi=_atan2(R[2, 1], -R[2, 0]))
    return sp.Matrix([values[c] for c in rep.components])


def _rotation_forms(rotation: str, trace: sp.Expr, v: Sequence[sp.Expr]) -> dict[str, sp.Expr]:
    """The unit quaternion (``qw >= 0``) or the rotation vector of a rotation matrix ``R``, given
    ``trace = tr R`` and ``v = (R32 - R23, R13 - R31, R21 - R12)`` (``= 2 sin(theta) u``).

    Quaternion, the ``qw >= 0`` branch: ``qw = sqrt(1 + tr R) / 2``, ``(qx, qy, qz) = v / (4 qw)``;
    valid where ``qw > 0`` (rotation angles below pi), where it equals the numeric quaternion
    (``w >= 0``); its derivatives grow as ``1/qw`` towards a half turn (the numeric ``J_r``'s singularity).

    Rotation vector: with ``c = (tr R - 1)/2`` and ``s = |v|/2`` (``cos theta``, ``sin theta``),
    ``theta = atan2(s, c)`` and ``r = theta / (2 s) v``; near the identity (``c >`` :data:`ROTVEC_SERIES_COS`)
    the series ``r = (1/2 + (1 - c)/6) v`` instead, so ``r`` and ``J_r`` are finite there (a
    ``Piecewise``). Valid for ``theta < pi``: at a half turn ``v = 0`` and the direction is lost.
    """
    if rotation == "quaternion":
        root = sp.sqrt(1 + trace)
        return {"qw": root / 2, "qx": v[0] / (2 * root), "qy": v[1] / (2 * root), "qz": v[2] / (2 * root)}
    c = (trace - 1) / 2
    s = sp.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2) / 2
    general = sp.atan2(s, c) / (2 * s)
    series = sp.Rational(1, 2) + (1 - c) / 6
    cond = c > sp.Float(ROTVEC_SERIES_COS, 17)
    return {name: sp.Piecewise((series * vi, cond), (general * vi, True)) for name, vi in zip(("rx", "ry", "rz"), v)}


def _quaternion_rotvec_task(T: sp.Matrix, rep: TaskRepresentation, variables: Sequence[sp.Symbol],
                            simplify: bool) -> tuple[sp.Matrix, sp.Matrix]:
    """``r`` and ``J_r`` of a quaternion or rotation-vector task, by the chain rule through the
    polynomial pieces ``tr R`` and ``v`` (:func:`_rotation_forms`): the pieces and their derivatives
    are expanded (and tidied with ``simplify``), the square roots and atan2 around them are not,
    so the forms stay the size of a few Jacobians (expanding them whole does not end for a UR5)."""
    R = T[:3, :3]
    tidy = (lambda e: _tidy(e, variables)) if simplify else (lambda e: e)
    pieces = [_clean(R[0, 0] + R[1, 1] + R[2, 2]), _clean(R[2, 1] - R[1, 2]), _clean(R[0, 2] - R[2, 0]),
              _clean(R[1, 0] - R[0, 1])]
    rates = [[tidy(_clean(sp.diff(p, q))) for q in variables] for p in pieces]
    P = sp.symbols("_P0:4", real=True, cls=sp.Dummy)
    forms = _rotation_forms(rep.rotation, P[0], P[1:])
    back = dict(zip(P, [tidy(p) for p in pieces]))
    rows_r, rows_J = [], []
    for comp in rep.components:
        if comp in ("px", "py", "pz"):
            e = T["xyz".index(comp[1]), 3]
            rows_r.append(e)
            rows_J.append([_clean(sp.diff(e, q)) for q in variables])
            if simplify:
                rows_r[-1] = tidy(e)
                rows_J[-1] = [tidy(d) for d in rows_J[-1]]
            continue
        f = forms[comp]
        partial = [sp.diff(f, p) for p in P]
        rows_r.append(f.xreplace(back))
        rows_J.append([sp.Add(*[d * rates[k][j] for k, d in enumerate(partial) if rates[k][j] != 0]).xreplace(back)
                       for j in range(len(variables))])
    return sp.Matrix(rows_r), sp.Matrix(len(rows_J), len(variables), [e for row in rows_J for e in row])


def _nest(e: sp.Expr, variables: Sequence[sp.Symbol]) -> sp.Expr:
    """Collect by the sines and cosines of the earliest joint variable, then recursively inside
    the coefficients: ``c1 (a2 c2 + a3 c23) - s1 d4`` rather than the flat sum."""
    if not e.is_Add:
        return e
    index = {v: i for i, v in enumerate(variables)}

    def key(atom):
        found = [index[s] for s in atom.free_symbols if s in index]
        return min(found) if found else None

    atoms = [a for a in e.atoms(sp.sin, sp.cos) if key(a) is not None]
    if not atoms:
        return e
    first = min(key(a) for a in atoms)
    group = sorted((a for a in atoms if key(a) == first), key=sp.default_sort_key)
    parts = sp.collect(e, group, evaluate=False)
    if len(parts) == len(e.args):  # nothing shared
        return e

    def term(f, c):
        c = _nest(sp.expand(c), variables)
        if c.is_Add and c.could_extract_minus_sign():  # -(d3 + q2) c1, not (-d3 - q2) c1
            return -(f * (-c))
        return f * c

    return sp.Add(*[term(f, c) for f, c in parts.items()])


def _shares_angles(e: sp.Expr) -> bool:
    """Some term multiplies sines or cosines of angles with a variable in common (``c1 c12``):
    the only terms :func:`TR10i` can combine (the composition's forms have none; world Jacobians may)."""
    for term in sp.Add.make_args(e):
        seen: set[sp.Symbol] = set()
        for factor in sp.Mul.make_args(term):
            base = factor.base if factor.is_Pow else factor
            if isinstance(base, (sp.sin, sp.cos)):
                syms = base.free_symbols
                if syms & seen or (factor.is_Pow and syms):
                    return True
                seen |= syms
    return False


def _tidy(e: sp.Expr, variables: Sequence[sp.Symbol]) -> sp.Expr:
    """The simplification of ``simplify=True``: sums of products of angles combined
    (``c1 c12 + s1 s12 = c2``), then collected by joint (:func:`_nest`); common factors of small
    entries are taken out when that makes them shorter."""
    if e.is_Number or e.is_Symbol:
        return e
    e = _clean(TR10i(e)) if _shares_angles(e) else e
    out = _nest(e, variables)
    if sp.count_ops(out) < SMALL_ENTRY_OPS:
        s = sp.factor_terms(out)
        if sp.count_ops(s) < sp.count_ops(out):
            out = s
    return out


def closed_forms(chain: SymbolicChain, what: Sequence[str] = ("transforms", "jacobian"), simplify: bool = False,
                 task: TaskRepresentation | None = None) -> ClosedForms:
    """Derive the closed forms of ``chain`` (see the module docstring).

    ``what``: ``transforms`` (the factors, frames and T; always computed), ``jacobian``
    (``local_world_aligned`` and ``world``, 6 x n), ``task`` (``r`` and ``J_r`` in ``task``, a
    :class:`~kinematics.algorithms.task.TaskRepresentation` with a symbolic rotation: ``rpy``,
    ``zyx``, ``zyz``, ``quaternion``, ``rotvec`` (:func:`_rotation_forms` says where those two are valid)
    or a named subset). ``simplify``: also sympy's ``simplify`` on every entry.
    """
    start = time.perf_counter()
    unknown = [w for w in what if w not in WHAT]
    if unknown:
        raise SymbolicError(f"what: {unknown[0]!r} is not one of {list(WHAT)}")
    if "task" in what:
        if task is None:
            raise SymbolicError("what: 'task' needs a representation")
        if task.rotation not in (None, *SYMBOLIC_ROTATIONS) and any(
                c not in ("px", "py", "pz") for c in task.components):
            raise SymbolicError(f"representation: {task.name!r} has no symbolic form here; use one of "
                                f"{list(SYMBOLIC_ROTATIONS) + list(PRESETS)} (the numeric task vectors have all)")
    n = chain.dof
    whole = _Composer()
    for s in chain.base:
        whole.step(s)
    frames: list[sp.Matrix] = []
    moving: list[tuple[Step, sp.Matrix, sp.Matrix]] = []  # (step, world axis, a point on it at q)
    for factor in chain.factors:
        for s in factor:
            axis = whole.step(s)
            if axis is not None:
                moving.append((s, axis, whole.p))
        frames.append(whole.pose())
    for s in chain.tool:
        whole.step(s)
    T = whole.pose()
    A = [_compose(f) for f in chain.factors]
    base = _compose(chain.base)
    tool = _compose(chain.tool)

    jacobians: dict[str, sp.Matrix] = {}
    if "jacobian" in what:
        p = T[:3, 3]
        lin = _expand(p.jacobian(sp.Matrix(chain.variables))) if n else sp.zeros(3, 0)
        ang = sp.zeros(3, n)
        screw_lin = sp.zeros(3, n)  # the space screws' linear parts: o x w (revolute), w (prismatic)
        for s, axis, point in moving:
            for k, q in enumerate(chain.variables):
                rate = sp.diff(s.value, q)
                if rate == 0:
                    continue
                if s.kind == "revolute":
                    ang[:, k] = ang[:, k] + rate * axis
                    screw_lin[:, k] = screw_lin[:, k] + rate * point.cross(axis)
                else:
                    screw_lin[:, k] = screw_lin[:, k] + rate * axis
        ang = _expand(ang)
        jacobians["local_world_aligned"] = lin.col_join(ang)
        jacobians["world"] = screw_lin.applyfunc(_reduce_squares).col_join(ang)
    task_forms = None
    if "task" in what and task.rotation in ("quaternion", "rotvec") and any(
            c not in ("px", "py", "pz") for c in task.components):
        task_forms = TaskForms(task, *_quaternion_rotvec_task(T, task, chain.variables, simplify), structured=True)
    elif "task" in what:
        r = _task_expressions(T, task)
        J_r = r.jacobian(sp.Matrix(chain.variables))
        task_forms = TaskForms(task, r, J_r.applyfunc(_clean))
    forms = ClosedForms(chain, A, base, tool, frames, T, jacobians, task_forms, simplify)
    if simplify:
        simplify_forms(forms)
    forms.seconds = time.perf_counter() - start
    return forms


def simplify_forms(forms: ClosedForms) -> None:
    """:func:`_tidy` on every entry of ``forms`` (in place)."""
    cache: dict[sp.Expr, sp.Expr] = {}
    variables = forms.chain.variables

    def simp(e):
        out = cache.get(e)
        if out is None:
            out = cache[e] = _tidy(e, variables)
        return out

    forms.T = forms.T.applyfunc(simp)
    forms.A = [a.applyfunc(simp) for a in forms.A]
    forms.frames = [f.applyfunc(simp) for f in forms.frames]
    forms.jacobians = {k: J.applyfunc(simp) for k, J in forms.jacobians.items()}
    if forms.task is not None and not forms.task.structured:
        forms.task = TaskForms(forms.task.representation, forms.task.r.applyfunc(simp),
                               forms.task.J_r.applyfunc(simp))
    forms.simplified = True


# ====================================================================== formats
def _compact_names(chain: SymbolicChain, expr_atoms) -> dict[sp.Expr, sp.Symbol]:
    """``cos(q1 + q2 + q4) -> c_{124}``, ``sin(q1) -> s_{1}`` (the notes' notation), for
    sines and cosines of sums of joint variables (``q`` style only)."""
    index = {v: i + 1 for i, v in enumerate(chain.variables)}
    if not all(v.name == f"q{i}" for v, i in index.items()):
        return {}
    out = {}
    for atom in expr_atoms:
        terms = sp.Add.make_args(atom.args[0])
        if all(t in index for t in terms):
            ids = sorted(index[t] for t in terms)
            sub = ("," if max(ids) > 9 else "").join(str(i) for i in ids)
            out[atom] = sp.Symbol(("c" if isinstance(atom, sp.cos) else "s") + "_{" + sub + "}")
    return out


def _latex_symbol_names(chain: SymbolicChain) -> dict[sp.Symbol, str]:
    names = {}
    for v in chain.variables:
        if not re.match(r"^q\d+$", v.name):
            names[v] = r"\mathrm{" + v.name.replace("_", r"\_") + "}"
    return names


def latex_matrix(M: sp.Matrix, chain: SymbolicChain) -> str:
    """LaTeX of a matrix or vector in the notes' compact notation (``c_{12}``, ``s_{1}``)."""
    compact = _compact_names(chain, M.atoms(sp.sin, sp.cos))
    return sp.latex(M.xreplace(compact), mat_str="bmatrix", mat_delim="",
                    symbol_names=_latex_symbol_names(chain))


def _text_matrix(M: sp.Matrix) -> list[list[str]]:
    return [[sp.sstr(M[i, j]) for j in range(M.cols)] for i in range(M.rows)]


def _variables_info(forms: ClosedForms) -> list[dict[str, str]]:
    return [{"symbol": v.name, "joint": j} for v, j in zip(forms.chain.variables, forms.chain.joints)]


def _matrices(forms: ClosedForms) -> dict[str, Any]:
    out: dict[str, Any] = {"T": forms.T, "A": forms.A, "base": forms.base, "tool": forms.tool}
    if forms.jacobians:
        out["jacobian"] = dict(forms.jacobians)
    if forms.task is not None:
        out["r"] = forms.task.r
        out["J_r"] = forms.task.J_r
    return out


def render(forms: ClosedForms, fmt: str, prefix: str = "") -> dict[str, Any]:
    """The closed forms in ``fmt``: ``latex`` (a LaTeX ``bmatrix`` per matrix), ``text``
    (nested lists of strings ``sympy.sympify`` reads), ``python`` or ``c`` (``code``: a module or
    a translation unit with the functions :func:`python_code` / :func:`c_code` describe).

    Always: ``joint_variables`` (``[{symbol, joint}]``, the order of q), ``parameters`` (names, the
    order of ``p`` in C), ``tip``, ``root``, ``simplified``; for a task, ``components``.
    """
    if fmt not in FORMATS:
        raise SymbolicError(f"format: {fmt!r} is not one of {list(FORMATS)}")
    out: dict[str, Any] = {
        "joint_variables": _variables_info(forms), "parameters": [p.name for p in forms.chain.parameters],
        "root": forms.chain.root, "tip": forms.chain.tip, "frames": list(forms.chain.frames),
        "simplified": forms.simplified, "format": fmt,
    }
    if forms.task is not None:
        out["representation"] = forms.task.representation.name
        out["components"] = list(forms.task.representation.labels)
    if fmt in ("latex", "text"):
        conv = (lambda M: latex_matrix(M, forms.chain)) if fmt == "latex" else _text_matrix
        for key, value in _matrices(forms).items():
            if isinstance(value, list):
                out[key] = [conv(M) for M in value]
            elif isinstance(value, dict):
                out[key] = {k: conv(M) for k, M in value.items()}
            else:
                out[key] = conv(value)
    elif fmt == "python":
        out["code"], out["functions"] = python_code(forms)
    else:
        out["code"], out["functions"] = c_code(forms, prefix)
    return out


_PY_RESERVED = {"q", "p", "numpy", "math", "out", "single", "T", "J"}


def _code_symbols(forms: ClosedForms) -> dict[sp.Symbol, sp.Symbol]:
    """Joint variables as ``q1 .. qn`` in generated code, whatever their display names."""
    return {v: sp.Symbol(f"q{i + 1}", real=True) for i, v in enumerate(forms.chain.variables)}


def _functions(forms: ClosedForms) -> list[tuple[str, str, sp.Matrix, tuple[int, ...]]]:
    """(name, what it returns, matrix, shape) of every generated function."""
    n = forms.chain.dof
    fs = [("fk", "T_world_tip = base A_1 ... A_n tool", forms.T, (4, 4))]
    frames = sp.Matrix.vstack(*forms.frames) if forms.frames else sp.zeros(0, 4)
    fs.append(("frames", f"T_world_frame_i for i = 1..{n}", frames, (n, 4, 4)))
    for ref, J in forms.jacobians.items():
        fs.append((f"jacobian_{ref}", f"6 x {n} Jacobian ({ref}, linear rows first)", J, (6, n)))
    if forms.task is not None:
        m = forms.task.r.rows
        labels = ", ".join(forms.task.representation.labels)
        fs.append(("task", f"task vector r = ({labels})", forms.task.r, (m,)))
        fs.append(("task_jacobian", f"{m} x {n} analytic Jacobian dr/dq", forms.task.J_r, (m, n)))
    return fs


def _check_code_names(forms: ClosedForms, reserved: set[str]) -> None:
    import keyword

    for p in forms.chain.parameters:
        if p.name in reserved or keyword.iskeyword(p.name) or p.name.startswith("_"):
            raise SymbolicError(f"parameter {p.name!r} cannot be a name in generated code; rename it")


def python_code(forms: ClosedForms) -> tuple[str, list[dict[str, str]]]:
    """A Python module (numpy only) with batched functions of the closed forms.

    Each function takes ``q`` (N, n) or (n,) in the order of ``joint_variables`` (and the
    parameters as keyword arguments, scalars or (N,) arrays) and returns (N, ...) arrays (no
    leading N for a single q): ``fk`` (4, 4), ``frames`` (n, 4, 4), ``jacobian_local_world_aligned``
    and ``jacobian_world`` (6, n), ``task`` (m,), ``task_jacobian`` (m, n).
    """
    _check_code_names(forms, _PY_RESERVED)
    chain = forms.chain
    n = chain.dof
    rename = _code_symbols(forms)
    printer = NumPyPrinter({"fully_qualified_modules": True, "inline": True})
    params = [p.name for p in chain.parameters]
    sig = "q" + (", *, " + ", ".join(params) if params else "")
    joints = "\n".join(f"    q{i + 1}: {j}" for i, j in enumerate(chain.joints))
    lines = [
        f'"""Closed forms of {chain.name} from {chain.root!r} to {chain.tip!r}, generated by kinematics',
        f"(kinematics.algorithms.symbolic). Joint variables, the columns of q:\n\n{joints}",
        "",
        ("Parameters (keyword arguments): " + ", ".join(params) if params else "No parameters."),
        '"""',
        "",
        "import numpy",
        "",
    ]
    functions = []
    for name, doc, M, shape in _functions(forms):
        entries = [e.xreplace(rename) for e in M]
        temps, reduced = sp.cse(entries, symbols=sp.numbered_symbols("_t"), order="none")
        lines += [
            "",
            f"def {name}({sig}):",
            f'    """{doc}: shape (N, {", ".join(map(str, shape))}) for q (N, {n}); no N for one q."""',
            "    q = numpy.asarray(q, dtype=float)",
            "    single = q.ndim == 1",
            "    q = numpy.atleast_2d(q)",
            f"    if q.ndim != 2 or q.shape[1] != {n}:",
            f'        raise ValueError(f"q must have {n} columns, got shape {{q.shape}}")',
        ]
        lines += [f"    q{i + 1} = q[:, {i}]" for i in range(n)]
        lines += [f"    {s} = {printer.doprint(e)}" for s, e in temps]
        lines.append(f"    out = numpy.zeros((q.shape[0], {', '.join(map(str, shape))}))")
        for flat, e in enumerate(reduced):
            if e != 0:
                idx = np.unravel_index(flat, shape) if shape else ()
                lines.append(f"    out[:, {', '.join(map(str, idx))}] = {printer.doprint(e)}")
        lines.append("    return out[0] if single else out")
        lines.append("")
        functions.append({"name": name, "signature": f"{name}({sig})", "returns": doc})
    return "\n".join(lines).rstrip() + "\n", functions


_C_RESERVED = {"q", "p", "T", "J", "r", "out", "M_PI", "main"} | {
    "auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else", "enum", "extern",
    "float", "for", "goto", "if", "inline", "int", "long", "register", "restrict", "return", "short", "signed",
    "sizeof", "static", "struct", "switch", "typedef", "union", "unsigned", "void", "volatile", "while",
    "y0", "y1", "yn", "j0", "j1", "jn", "fabs", "round", "trunc"}


def c_code(forms: ClosedForms, prefix: str = "") -> tuple[str, list[dict[str, str]]]:
    """A C99 translation unit (``math.h`` only) with one function per closed form:

    ``void <prefix>fk(const double *q, double *T)`` (``T``: 16 doubles, row-major), ``frames``
    (n x 16), ``jacobian_local_world_aligned`` and ``jacobian_world`` (``J``: 6 x n, row-major),
    ``task`` (m) and ``task_jacobian`` (m x n). With parameters every function takes
    ``const double *p`` after ``q`` (in the order of ``parameters``). Compile with ``cc -O2 -c``
    (link ``-lm``).
    """
    if not re.match(r"^[A-Za-z_]?[A-Za-z0-9_]*$", prefix or "") or len(prefix) > 64:
        raise SymbolicError(f"prefix: {prefix!r} is not a C identifier prefix")
    _check_code_names(forms, _C_RESERVED)
    chain = forms.chain
    n = chain.dof
    rename = _code_symbols(forms)
    printer = C99CodePrinter()
    params = [p.name for p in chain.parameters]
    pdecl = "const double *p, " if params else ""
    joints = "\n".join(f" *   q[{i}] = q{i + 1}: {j}" for i, j in enumerate(chain.joints))
    lines = [
        f"/* Closed forms of {chain.name} from '{chain.root}' to '{chain.tip}', generated by kinematics",
        " * (kinematics.algorithms.symbolic). Matrices are row-major; Jacobians have the linear rows first.",
        " * Joint values:",
        joints,
    ]
    if params:
        lines.append(" * Parameters: " + ", ".join(f"p[{i}] = {name}" for i, name in enumerate(params)))
    lines += [" */", "#include <math.h>", "#ifndef M_PI", "#define M_PI 3.14159265358979323846", "#endif", ""]
    functions = []
    for name, doc, M, shape in _functions(forms):
        out_name = {"fk": "T", "frames": "T"}.get(name, "J" if "jacobian" in name else "r")
        entries = [e.xreplace(rename) for e in M]
        temps, reduced = sp.cse(entries, symbols=sp.numbered_symbols("_t"), order="none")
        signature = f"void {prefix}{name}(const double *q, {pdecl}double *{out_name})"
        size = int(np.prod(shape)) if shape else 1
        lines += [f"/* {doc}: {size} doubles */", signature, "{"]
        lines += [f"    const double q{i + 1} = q[{i}];" for i in range(n)]
        lines += [f"    const double {name_} = p[{i}];" for i, name_ in enumerate(params)]
        lines += [f"    const double {s} = {printer.doprint(e)};" for s, e in temps]
        lines += [f"    {out_name}[{k}] = {printer.doprint(e)};" for k, e in enumerate(reduced)]
        lines += ["}", ""]
        functions.append({"name": prefix + name, "signature": signature, "returns": doc})
    return re.sub(r"\n\n\n+", "\n\n", "\n".join(lines)).rstrip() + "\n", functions


# ====================================================================== time limit
_CONTEXT = None


def _context():
    global _CONTEXT
    if _CONTEXT is None:
        methods = multiprocessing.get_all_start_methods()
        ctx = multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")
        if ctx.get_start_method() == "forkserver":
            ctx.set_forkserver_preload([__name__])
        _CONTEXT = ctx
    return _CONTEXT


def _worker(conn, fn, args) -> None:
    try:
        message = ("ok", fn(*args))
    except KinematicsError as exc:
        message = ("error", type(exc).__name__, str(exc))
    except RecursionError:
        message = ("error", "SymbolicError", "the expressions are too deeply nested to handle; "
                   "ask with simplify: false or for a shorter chain")
    except BaseException:  # noqa: BLE001 - reported to the parent, which raises
        message = ("bug", traceback.format_exc())
    try:
        conn.send(message)
    except Exception:  # noqa: BLE001 - e.g. an answer that cannot be pickled
        conn.send(("bug", traceback.format_exc()))
    finally:
        conn.close()


#: seconds between two looks at the caller's cancellation token while the worker runs
CANCEL_POLL_SECONDS = 0.05


def run_with_timeout(fn: Callable, args: tuple, timeout: float | None):
    """``fn(*args)`` in a worker process killed after ``timeout`` seconds
    (:class:`~kinematics.errors.SymbolicTimeoutError`); ``timeout=None`` runs it here, unbounded.

    The workers fork from a server process that has sympy loaded (``forkserver``), so a call
    costs a fork, not an import. ``fn``, ``args`` and the result travel by pickle. As with any
    use of :mod:`multiprocessing`, a script that calls this must guard its top level with
    ``if __name__ == "__main__":`` (each worker imports the main module under another name).
    Inside a :func:`kinematics.engine.cancel.cancellable` block the worker is also killed when the
    token is cancelled or its time budget runs out (its error is raised).
    """
    if timeout is None:
        return fn(*args)
    if not (isinstance(timeout, (int, float)) and math.isfinite(timeout) and timeout > 0):
        raise SymbolicError(f"timeout: {timeout!r} is not a positive number of seconds")
    from ..engine import cancel

    token = cancel.current()  # a caller's cancellation (a client that went away) also kills the worker
    ctx = _context()
    receiver, sender = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_worker, args=(sender, fn, args), daemon=True)
    proc.start()
    sender.close()
    try:
        deadline = time.monotonic() + timeout
        answered = receiver.poll(timeout if token is None else min(timeout, CANCEL_POLL_SECONDS))
        while not answered and token is not None and time.monotonic() < deadline:
            token.check()
            answered = receiver.poll(max(0.0, min(deadline - time.monotonic(), CANCEL_POLL_SECONDS)))
        if not answered:
            raise SymbolicTimeoutError(
                f"the closed forms took longer than the time limit of {timeout:g} s; ask with simplify: false "
                "(the expanded forms come fast), for fewer results (what), or for a shorter chain", timeout=timeout)
        try:
            message = receiver.recv()
        except EOFError:
            raise SymbolicError("the closed-form worker ended without an answer: out of memory (ask with simplify: "
                                "false or for a shorter chain), or a script that calls this at import time (guard "
                                "it with `if __name__ == '__main__':`, as multiprocessing requires)") from None
    finally:
        if proc.is_alive():
            proc.kill()
        proc.join(5)
        receiver.close()
    if message[0] == "ok":
        return message[1]
    if message[0] == "error":
        from .. import errors

        cls = getattr(errors, message[1], None)
        try:
            exc = cls(message[2]) if isinstance(cls, type) and issubclass(cls, KinematicsError) else None
        except TypeError:  # a class with required keyword arguments
            exc = None
        raise exc if exc is not None else SymbolicError(message[2])
    raise RuntimeError(f"the closed-form worker failed:\n{message[1]}")


def _job(chain: SymbolicChain, what: tuple[str, ...], simplify: bool, task: TaskRepresentation | None, fmt: str,
         prefix: str) -> tuple[ClosedForms, dict[str, Any]]:
    forms = closed_forms(chain, what, simplify, task)
    return forms, render(forms, fmt, prefix)


def derive(chain: SymbolicChain, *, what: Sequence[str] = ("transforms",), simplify: bool = True,
           task: TaskRepresentation | None = None, fmt: str = "latex", prefix: str = "",
           timeout: float | None = DEFAULT_TIMEOUT) -> tuple[ClosedForms, dict[str, Any]]:
    """:func:`closed_forms` and :func:`render` under a time limit (:func:`run_with_timeout`)."""
    if fmt not in FORMATS:
        raise SymbolicError(f"format: {fmt!r} is not one of {list(FORMATS)}")
    what = tuple(dict.fromkeys(what))
    return run_with_timeout(_job, (chain, what, bool(simplify), task, fmt, prefix), timeout)
