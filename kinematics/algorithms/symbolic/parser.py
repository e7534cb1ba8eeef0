"""Numbers, expressions and DH tables of closed forms: floating-point numbers made exact where
they are simple (:func:`exact_number`, :func:`exact_angle`), table entries parsed from text
(:func:`parse_expression`: numbers, parameter names, ``+ - * / ^``, ``pi``, ``sqrt``; nothing is
evaluated), and symbolic DH tables (:func:`symbolic_table_from_dict`), validated by the numeric
tables' reader (:func:`kinematics.io.dh_table.read_table`).
"""

from __future__ import annotations

import decimal
import math
import re
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
import sympy as sp

from ...errors import DHError, SymbolicError
from ...io import dh_table as dh

#: most moving joints on a chain whose closed forms are derived
MAX_SYMBOLIC_JOINTS = 24
#: longest expression accepted in a table entry (characters)
MAX_EXPRESSION_LENGTH = 200
#: a number within this many units in the last place of a simple value is that value
SNAP_ULPS = 4
#: decimals with at most this many significant digits become exact rationals
MAX_DECIMAL_DIGITS = 12

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
class SymbolicDHTable(dh.TableRows):
    """A DH table with symbolic entries (:func:`symbolic_table_from_dict`); base and tool are numeric."""

    name: str
    convention: str
    rows: tuple[SymbolicDHRow, ...]
    base: np.ndarray
    tool: np.ndarray
    angles: str = "radians"

    @property
    def parameters(self) -> tuple[sp.Symbol, ...]:
        syms = set()
        for r in self.rows:
            for e in (r.a, r.alpha, r.d, r.theta):
                syms |= e.free_symbols
        return tuple(sorted(syms, key=lambda s: s.name))


def _entry(value: Any, where: str, angle: bool, degrees: bool) -> sp.Expr:
    """One entry of a symbolic table (a :data:`kinematics.io.dh_table.Entry`): a number, checked as
    the numeric tables check it and made exact where it is simple, or an expression of parameters."""
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
        v = dh._number(number, where)  # finite, within the bounds of every table entry
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
    becomes ``pi*alpha1/180``). Base and tool are numeric (4x4 or ``{xyz, rpy}``). The fields are
    validated by the numeric tables' own reader (:func:`kinematics.io.dh_table.read_table`), each
    entry made by :func:`_entry`; errors are :class:`~kinematics.errors.DHError` naming the field.

    >>> t = symbolic_table_from_dict({"joints": [{"type": "P", "a": "a1", "alpha": "pi/2", "d": 0, "theta": 0}]})
    >>> (t.rows[0].type, t.rows[0].a, t.rows[0].alpha, t.parameters)
    ('prismatic', a1, pi/2, (a1,))
    """
    f = dh.read_table(d, _entry, max_rows=MAX_SYMBOLIC_JOINTS, reserved=False,
                      rows_limit=f"closed forms are derived for at most {MAX_SYMBOLIC_JOINTS}")
    return SymbolicDHTable(f.name, f.convention, tuple(SymbolicDHRow(**r) for r in f.rows), f.base, f.tool, f.angles)
