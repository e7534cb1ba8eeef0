"""Composition and closed forms: the pose of a chain kept as ``R_s Rot(w, Theta) C`` (consecutive
parallel axes add their angles), the Jacobians, task vectors and their analytic Jacobians, and
the tidying of ``simplify=True`` (:func:`closed_forms`)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Sequence

import sympy as sp
from sympy.simplify.fu import TR10i

from ...errors import SymbolicError
from ..task import PRESETS, TaskRepresentation
from .chains import _ZERO3, Step, SymbolicChain
from .parser import exact_number

WHAT = ("transforms", "jacobian", "task")
#: the Jacobians of a closed form (Pinocchio's meaning; linear rows first)
JACOBIAN_REFERENCES = ("local_world_aligned", "world")
#: rotation representations with symbolic task vectors: atan2 forms (Euler angles); the quaternion's
#: qw >= 0 branch (valid where qw > 0); the rotation vector through atan2 (valid for angles below pi)
SYMBOLIC_ROTATIONS = ("rpy", "zyx", "zyz", "quaternion", "rotvec")
#: the rotation vector's closed form switches to its series ``(1/2 + (1 - cos theta)/6) v`` when
#: ``cos theta`` is above this (theta below 1e-4 rad: the series' error is below 1e-18 rad there)
ROTVEC_SERIES_COS = 1 - 5e-9
#: terms whose floating-point coefficient is below this are rounding residue and dropped (a term
#: is at most |coefficient| x |q|, so even at |q| = 1e6 this is 1e-14 m)
CHOP = 1e-20
#: entries with fewer operations than this also get their common factors taken out (kept when shorter)
SMALL_ENTRY_OPS = 40


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
