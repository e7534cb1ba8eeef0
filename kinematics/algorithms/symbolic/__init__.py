"""Closed forms of serial chains with sympy: the factors ``A_i``, ``T(q)``, Jacobians and task
vectors, printed as LaTeX, Python (numpy), C or text.

The only package of the library that imports sympy (import contract ``one-sympy``; the
``symbolic`` extra): :mod:`.parser` (numbers, expressions, symbolic DH tables), :mod:`.chains`,
:mod:`.composition` (closed forms), :mod:`.codegen` (LaTeX, text, Python, C) and :mod:`.worker`
(the time limit). Their public names are importable from here.

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
so ``T`` comes out in the textbooks' compact terms (``c_12``, ``s_124``) without trigonometric
search.
``simplify=True`` then runs sympy's ``simplify`` on every entry (factoring ``s1 d2 + s1 d3``
into ``s1 (d2 + d3)``); that is the slow part, and :func:`run_with_timeout` bounds it.

The RPR arm of the forward-kinematics example in Spong's convention has
``T3_0 = [[c1 c3, -c1 s3, s1, s1 (d2 + d3)], ...]``:

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

from ...errors import MissingExtraError

try:
    import sympy  # noqa: F401
except ImportError as exc:  # the `symbolic` extra
    raise MissingExtraError.of("symbolic", "closed forms", "sympy") from exc

from .chains import VARIABLE_STYLES, Step, SymbolicChain, chain_from_model, chain_from_table, chain_tip
from .codegen import FORMATS, c_code, latex_matrix, python_code, render
from .composition import (
    CHOP,
    JACOBIAN_REFERENCES,
    ROTVEC_SERIES_COS,
    SMALL_ENTRY_OPS,
    SYMBOLIC_ROTATIONS,
    WHAT,
    ClosedForms,
    TaskForms,
    closed_forms,
    simplify_forms,
)
from .parser import (
    MAX_DECIMAL_DIGITS,
    MAX_EXPONENT,
    MAX_EXPRESSION_LENGTH,
    MAX_SYMBOLIC_JOINTS,
    SNAP_ULPS,
    SymbolicDHRow,
    SymbolicDHTable,
    exact_angle,
    exact_number,
    parameter_symbol,
    parse_expression,
    symbolic_table_from_dict,
)
from .worker import CANCEL_POLL_SECONDS, DEFAULT_TIMEOUT, derive, run_with_timeout

__all__ = [
    "VARIABLE_STYLES", "Step", "SymbolicChain", "chain_from_model", "chain_from_table", "chain_tip",
    "FORMATS", "c_code", "latex_matrix", "python_code", "render",
    "CHOP", "JACOBIAN_REFERENCES", "ROTVEC_SERIES_COS", "SMALL_ENTRY_OPS", "SYMBOLIC_ROTATIONS", "WHAT",
    "ClosedForms", "TaskForms", "closed_forms", "simplify_forms",
    "MAX_DECIMAL_DIGITS", "MAX_EXPONENT", "MAX_EXPRESSION_LENGTH", "MAX_SYMBOLIC_JOINTS", "SNAP_ULPS",
    "SymbolicDHRow", "SymbolicDHTable", "exact_angle", "exact_number", "parameter_symbol", "parse_expression",
    "symbolic_table_from_dict", "CANCEL_POLL_SECONDS", "DEFAULT_TIMEOUT", "derive", "run_with_timeout",
]
