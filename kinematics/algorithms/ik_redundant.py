"""Every solution of a redundant chain (seven joints for a pose): its self-motion, slice by slice.

A chain with one joint more than its task reaches a pose along a one-dimensional set, its
**self-motion**. Running a *parameter* ψ along it -- the value of one of its joints -- cuts the set
into **slices**: at ψ = v the solutions are those of the six-joint chain with that joint locked at v,
which :func:`kinematics.algorithms.ik_all.all_solutions` lists completely (the closed form of the
locked chain's family, or the general-6R elimination where it has none).

:class:`SelfMotion` answers slices for many (target, value) pairs at once:

- the parameter joint at an **end** of the chain (the Panda's q7): locking it at v is locking it at a
  reference value v0 and moving the target, ``T' = T M⁻¹ E_j(v0 − v) M`` (last joint, ``M`` the
  chain's home pose) or ``T' = E_j(v0 − v) T`` (first joint), so every pair is one more target of
  **one** locked chain: a single batched call of the compiled kernels;
- a joint inside the chain (the iiwa's q3): one locked chain per distinct value (its family is read
  again each time: about a millisecond a value, then the targets of that value in one batch).

Slices are solved with the limits ignored (each branch once, angles in (−π, π]); the caller applies
the limits. Along ψ each solution moves smoothly on a **branch**; branches end where two meet (the
locked chain is singular there: two solutions become one). :mod:`kinematics.algorithms.ik_self_motion`
tracks the branches over an adaptive grid, finds the ends of the in-limit ranges by bisection on the
slices themselves (to :data:`PSI_TOLERANCE`) and optimises an objective along them.

>>> from kinematics.io import default_catalogue
>>> panda = default_catalogue().get("panda")
>>> choice = parameters(panda, "panda_link8")
>>> choice.default, choice.families["panda_joint7"], choice.families["panda_joint1"]
('panda_joint7', 'spherical_shoulder_intersecting_12', 'general_6r')
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from ..engine.poe import compile_model
from ..errors import BudgetError, KinematicsError, LockedJointError, did_you_mean
from ..model.derived import PerModel
from ..model.robot import Limits, RobotModel
from ..spatial.transforms import exp_screws, inverse_transform
from ..tolerances import DEFAULT_POSITION_TOLERANCE, DEFAULT_ROTATION_TOLERANCE, LIMIT_TOLERANCE
from .ik import pose_errors
from .ik_all import SINGULAR, all_copies, all_solutions  # noqa: F401 (SINGULAR: the answers' flag)
from .ik_families import SUBPROBLEM_KERNELS, Chain, detect, reduce_chain, validate_locked

#: what ``select`` optimises: the distance to the seed (least), the normalised limit margin (largest),
#: Yoshikawa's manipulability √det(J Jᵀ) (largest)
OBJECTIVES = ("nearest", "margin", "manipulability")
#: interval ends and optima are found to this (rad or m of the parameter)
PSI_TOLERANCE = 1e-13
#: the branches are followed on solutions within this (m and rad): exact ones, no least-squares points
TRACK_TOLERANCE = 1e-10
#: the first grid over the parameter's range (points), and how many times a cell may be halved
GRID, REFINE_ROUNDS = 64, 10
#: two solutions on neighbouring grid points are one branch when no joint moved more than this (rad or m)
MATCH = 0.35
#: configurations sampled to see which joints move along the self-motion
MOTION_SAMPLES = 64
#: a joint whose median share of the self-motion (null space of the Jacobian) is below this does not
#: run along it (the elbow of an arm with a spherical shoulder and wrist)
STILL = 1e-3
#: where in a joint's range its locking is tried (fractions: generic values, no axes aligned by chance)
GENERIC = (0.3819660112501051, 0.7236067977499789)
#: values a request may give (targets x values), before the caller's budget
MAX_PAIRS = 1_000_000


@dataclass(frozen=True)
class Redundancy:
    """How to run along a redundant chain's self-motion (a frozen request option).

    ``parameter``: a joint name (None: :attr:`Parameters.default`); ``values``: None, (K,) for every
    target or (N, K), one row per target; ``intervals``: answer the in-limit ranges; ``select``: one of
    :data:`OBJECTIVES` or None."""

    parameter: str | None = None
    values: np.ndarray | None = None
    intervals: bool = False
    select: str | None = None

    @classmethod
    def of(cls, spec: "Redundancy | dict | None") -> "Redundancy":
        """A :class:`Redundancy` from itself or a request's map ``{parameter, values, intervals, select}``
        (``parameter``: a name, ``{"joint": name}``); bad fields raise :class:`KinematicsError` naming them."""
        if isinstance(spec, Redundancy):
            return spec
        spec = dict(spec or {})
        unknown = set(spec) - {"parameter", "values", "intervals", "select"}
        if unknown:
            raise KinematicsError(f"redundancy: unknown field(s) {', '.join(sorted(unknown))}")
        p = spec.get("parameter")
        if isinstance(p, dict):
            if set(p) != {"joint"}:
                raise KinematicsError("redundancy.parameter: give {\"joint\": name}")
            p = p["joint"]
        if p == "sew":
            raise KinematicsError("redundancy.parameter: 'sew' (the shoulder-elbow-wrist angle) is not available in "
                                  "this version; give {\"joint\": name}")
        if p is not None and not isinstance(p, str):
            raise KinematicsError(f"redundancy.parameter: {p!r} is not a joint name")
        values = spec.get("values")
        if values is not None:
            try:
                values = np.array(values, dtype=float)
            except (TypeError, ValueError):
                raise KinematicsError("redundancy.values: give numbers (one list, or one list per target)") from None
            if values.ndim not in (1, 2):
                raise KinematicsError("redundancy.values: give one list, or one list per target")
            if not np.all(np.isfinite(values)):
                raise KinematicsError("redundancy.values: every value must be finite (NaN or infinity given)")
            values.setflags(write=False)
        select = spec.get("select")
        if select is not None and select not in OBJECTIVES:
            raise KinematicsError(f"redundancy.select: {select!r} is not one of {', '.join(OBJECTIVES)}")
        if values is None and not spec.get("intervals") and select is None:
            raise KinematicsError("redundancy: give values, intervals: true or select")
        return cls(p, values, bool(spec.get("intervals", False)), select)


# ---------------------------------------------------------------------------------- the parameter
@dataclass(frozen=True)
class Parameters:
    """Which joints of a redundant chain run along its self-motion with a closed form when locked:
    ``joints`` (chain order), ``families`` (the locked chain's family per joint), ``default`` (the
    subproblem closed form, exact before near, whose joint moves most along the self-motion; else the
    general-6R elimination likewise), ``chain`` (the seven-joint chain)."""

    joints: tuple[str, ...]
    families: dict
    default: str
    chain: Chain
    motion: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        return {"redundant": True, "default_parameter": {"joint": self.default},
                "parameters": [{"joint": j, "family": self.families[j]} for j in self.joints]}


def _lock_value(model: RobotModel, name: str, at: float = 0.5) -> float:
    """A value of joint ``name`` at the fraction ``at`` of its range (of (−π, π) when unlimited)."""
    i = model.q_index[name]
    lo, hi = model.lower_limits[i], model.upper_limits[i]
    lo, hi = (lo, hi) if np.isfinite(lo) and np.isfinite(hi) else (-np.pi, np.pi)
    return float(lo + at * (hi - lo))


def redundant_chain(model: RobotModel, link: str, locked: dict | None = None, tool=None) -> Chain:
    """The chain to ``link`` with ``locked`` folded in, refused unless it has one joint more than a pose."""
    chain = reduce_chain(model, link, locked, tool)
    if chain.n > 7:
        raise KinematicsError(f"the chain to {link} has {chain.n} free joints: redundancy runs along one "
                              f"free joint more than a pose; lock {chain.n - 7} of them (locked)")
    if chain.n < 7:
        raise KinematicsError(f"redundancy: the chain to {link} has {chain.n} free joints, not 7: it is not "
                              "redundant (its solutions are finitely many; leave redundancy out)")
    if chain.mimic:
        raise KinematicsError(f"redundancy: the chain to {link} has a mimic joint (no closed form)")
    return chain


_parameter_cache = PerModel(lambda model: {})


def parameters(model: RobotModel, link: str, locked: dict | None = None, tool=None) -> Parameters:
    """The :class:`Parameters` of the redundant chain to ``link`` (kept per model)."""
    key = (link, tuple(sorted(validate_locked(model, locked).items())),
           None if tool is None else np.asarray(tool, dtype=float).tobytes())
    cache = _parameter_cache(model)
    if key not in cache:
        chain = redundant_chain(model, link, locked, tool)
        share = _motion_share(model, link, chain, locked, tool)
        fams, rank = {}, {}
        for k, name in enumerate(chain.joints):
            # at two generic values (a special one can align axes: the Panda's q5 = 0)
            fam, other = (detect(reduce_chain(model, link, {**(locked or {}), name: _lock_value(model, name, at)},
                                              tool)) for at in GENERIC)
            if not fam.closed_form or fam.name != other.name or share[k] < STILL:
                continue
            fams[name] = fam.name
            rank[name] = (fam.kernel in SUBPROBLEM_KERNELS, not fam.near, share[k])
        if not fams:
            raise KinematicsError(f"redundancy: no joint of the chain to {link} leaves a closed form when locked")
        default = max(rank, key=rank.get)
        cache[key] = Parameters(tuple(fams), fams, default, chain, dict(zip(chain.joints, share.tolist())))
    return cache[key]


def _motion_share(model, link, chain, locked, tool) -> np.ndarray:
    """Median over :data:`MOTION_SAMPLES` configurations (deterministic) of each joint's share |n_j|
    of the unit self-motion direction n (the Jacobian's null space)."""
    rng = np.random.default_rng(0)
    lo = np.where(np.isfinite(model.lower_limits), model.lower_limits, -np.pi)
    hi = np.where(np.isfinite(model.upper_limits), model.upper_limits, np.pi)
    Q = lo + (hi - lo) * rng.random((MOTION_SAMPLES, model.dof))
    for name, v in validate_locked(model, locked).items():
        Q[:, model.q_index[name]] = v
    J = compile_model(model).jacobian(Q, link, "local_world_aligned", tool=tool)[:, :, chain.columns]
    null = np.linalg.svd(J)[2][:, -1]
    return np.median(np.abs(null), axis=0)


def family_fields(model: RobotModel, link: str, locked: dict | None = None, tool=None) -> dict:
    """The redundancy fields of a family answer: ``{redundant: false}`` unless the chain has seven free
    joints, else :meth:`Parameters.as_dict` (no closed-form parameter: ``default_parameter`` None)."""
    if reduce_chain(model, link, locked, tool).n != 7:
        return {"redundant": False}
    try:
        return parameters(model, link, locked, tool).as_dict()
    except KinematicsError:
        return {"redundant": True, "default_parameter": None, "parameters": []}


def parameter_joint(model: RobotModel, chain: Chain, name: str | None, default: Callable[[], str]) -> str:
    """``name`` checked as a free joint of ``chain`` (None: ``default()``)."""
    if name is None:
        return default()
    if name not in model.q_index:
        raise LockedJointError(f"redundancy.parameter: {name!r} is not a joint of {model.name}"
                               f"{did_you_mean(name, model.joint_names, 'joints')}", joint=str(name))
    if name not in chain.joints:
        raise LockedJointError(f"redundancy.parameter: {name!r} is not a free joint of the chain to {chain.link} "
                               f"({', '.join(chain.joints)})", joint=name)
    return name


# ---------------------------------------------------------------------------------- slices
def _without_limits(model: RobotModel) -> RobotModel:
    joints = tuple(replace(j, limits=Limits(-np.inf, np.inf, j.limits.effort, j.limits.velocity))
                   if j.limits is not None else j for j in model.joints)
    return replace(model, joints=joints)


_unlimited = PerModel(_without_limits)


@dataclass(frozen=True, eq=False)
class Slices:
    """Solutions of R (target, value) pairs, limits ignored: ``q`` (R, K, dof) NaN-padded, ``count``
    (R,), ``singular`` (R, K) (the locked chain's Jacobian: where branches meet), ``position_error``,
    ``rotation_error`` (R, K) measured on the real model, ``complete`` (R,), ``family``, ``method``."""

    q: np.ndarray
    count: np.ndarray
    singular: np.ndarray
    position_error: np.ndarray
    rotation_error: np.ndarray
    complete: np.ndarray
    family: str
    method: str


class SelfMotion:
    """Slices of the self-motion of ``model``'s chain to ``link`` (``tool`` on it, ``locked`` other
    joints), parameter ``joint`` (None: the default of :func:`parameters`). Targets are root-frame poses."""

    def __init__(self, model: RobotModel, link: str, joint: str | None = None, *, locked: dict | None = None,
                 tool=None, seed: np.ndarray | None = None, position_tolerance: float = DEFAULT_POSITION_TOLERANCE,
                 rotation_tolerance: float = DEFAULT_ROTATION_TOLERANCE):
        self.model, self.link, self.tool = model, link, tool
        self.locked = validate_locked(model, locked)
        self.chain = redundant_chain(model, link, self.locked, tool)
        self.joint = parameter_joint(model, self.chain, joint,
                                     lambda: parameters(model, link, self.locked, tool).default)
        self.k = self.chain.joints.index(self.joint)
        self.column = int(self.chain.columns[self.k])
        self.revolute = bool(self.chain.revolute[self.k])
        self.seed = seed
        self.tolerances = dict(position_tolerance=position_tolerance, rotation_tolerance=rotation_tolerance)
        self.end = self.k in (0, self.chain.n - 1)
        self.v0 = _lock_value(model, self.joint, GENERIC[0])
        lo, hi = model.lower_limits[self.column], model.upper_limits[self.column]
        self.lower, self.upper = float(lo), float(hi)
        self.poe = compile_model(model)
        cols = self.chain.columns
        lo, hi = model.lower_limits[cols], model.upper_limits[cols]
        self._limits = (cols, lo, hi, self.chain.revolute & ~model.continuous[cols] & np.isfinite(lo) & np.isfinite(hi))

    def margins(self, q: np.ndarray) -> np.ndarray:
        """Each chain joint's distance inside its limits (..., n) at ``q`` (..., dof), its best ``2πk``
        copy for a revolute joint with finite limits (negative: outside, by that much)."""
        cols, lo, hi, periodic = self._limits
        x = np.asarray(q)[..., cols]
        best = np.minimum(x - lo, hi - x)
        for k in (-2, -1, 1, 2):
            y = x + 2 * np.pi * k
            best = np.where(periodic, np.maximum(best, np.minimum(y - lo, hi - y)), best)
        return best

    def family_name(self) -> str:
        """The family of the chain with the parameter joint locked (at a generic value)."""
        return detect(reduce_chain(self.model, self.link, {**self.locked, self.joint: self.v0}, self.tool)).name

    @property
    def cost(self) -> str:
        return ("one locked chain for every value (the value moves the target)" if self.end
                else "one locked chain per distinct value")

    def _E(self, theta: np.ndarray) -> np.ndarray:
        c = self.chain
        return exp_screws(c.h[self.k][None], c.r[self.k][None], np.array([self.revolute]),
                          np.asarray(theta, float)[:, None])[:, 0]

    def solve(self, T_root: np.ndarray, psi: np.ndarray, exact: bool = False) -> Slices:
        """Every solution (limits ignored) at each pair (``T_root[r]``, ``psi[r]``): a :class:`Slices`.
        ``exact``: within :data:`TRACK_TOLERANCE` (not the request's tolerances: past the end of a
        branch the closed form's least-squares point is within those, near the end)."""
        tolerances = dict(position_tolerance=TRACK_TOLERANCE, rotation_tolerance=TRACK_TOLERANCE) if exact \
            else self.tolerances
        T_root = np.asarray(T_root, float).reshape(-1, 4, 4)
        psi = np.asarray(psi, float).reshape(-1)
        R = len(psi)
        seed = None if self.seed is None else np.broadcast_to(self.seed, (R, self.model.dof))
        if self.end:
            E = self._E(self.v0 - psi)
            if self.k == 0:
                G = np.matmul(E, T_root)
            else:
                M = self.chain.M
                G = T_root @ inverse_transform(M) @ E @ M
            sol = all_solutions(self.model, self.link, G, tool=self.tool, locked={**self.locked, self.joint: self.v0},
                                limits="ignore", seed=seed, **tolerances)
            q, count, sing, complete = sol.q.copy(), sol.count, sol.singular, sol.complete
            family, method = sol.family.name, sol.method
        else:
            parts, family, method = {}, "", "analytic"
            unlimited = _unlimited(self.model)
            for v in np.unique(psi):
                rows = np.flatnonzero(psi == v)
                sol = all_solutions(unlimited, self.link, T_root[rows], tool=self.tool,
                                    locked={**self.locked, self.joint: float(v)}, limits="ignore",
                                    seed=None if seed is None else seed[rows], **tolerances)
                parts[float(v)] = (rows, sol)
                family, method = sol.family.name, sol.method if method == "analytic" else method
            K = max((s.q.shape[1] for _, s in parts.values()), default=0)
            q = np.full((R, K, self.model.dof), np.nan)
            count = np.zeros(R, np.int64)
            sing = np.zeros((R, K), bool)
            complete = np.ones(R, bool)
            for rows, s in parts.values():
                k = s.q.shape[1]
                q[rows, :k], count[rows], sing[rows, :k], complete[rows] = s.q, s.count, s.singular, s.complete
        listed = np.arange(q.shape[1])[None, :] < count[:, None]
        q[..., self.column] = np.where(listed, psi[:, None], np.nan)
        pe = np.full(listed.shape, np.nan)
        re = np.full(listed.shape, np.nan)
        if listed.any():
            F = self.poe.fk(q[listed], [self.link], tool=self.tool)[:, 0]
            pe[listed], re[listed] = pose_errors(F, np.repeat(T_root, count, axis=0))
        return Slices(q, count, sing & listed, pe, re, complete, family, method)


# ---------------------------------------------------------------------------------- limits
def in_limit_copies(model: RobotModel, chain: Chain, q: np.ndarray, count: np.ndarray):
    """The solutions ``q`` (R, K, dof) with ``count`` (R,) under the limits: every ``q + 2πk`` copy
    within them (as :func:`~kinematics.algorithms.ik_all.all_solutions` lists them): rows (R', dof)
    and their pair (R',)."""
    listed = np.arange(q.shape[1])[None, :] < count[:, None]
    owner = np.repeat(np.arange(len(count)), count)
    return all_copies(model, chain, q[listed], owner)


def _wrapped(d: np.ndarray, revolute: np.ndarray) -> np.ndarray:
    return np.where(revolute, np.mod(d + np.pi, 2 * np.pi) - np.pi, d)


def check_values(motion: SelfMotion, values: np.ndarray, N: int, limits: str) -> np.ndarray:
    """``values`` (K,) or (N, K) as (N, K); in ``limits: "ignore"`` a revolute parameter's value is
    read modulo 2π (kept as given)."""
    V = np.asarray(values, float)
    if V.ndim == 1:
        V = np.broadcast_to(V, (N, V.size))
    if V.shape[0] != N:
        raise KinematicsError(f"redundancy.values: {V.shape[0]} lists for {N} targets (give one list, or one per target)")
    if V.size > MAX_PAIRS:
        raise BudgetError(f"redundancy.values: {V.size} (target, value) pairs, at most {MAX_PAIRS}",
                          budget="batch", field="redundancy.values", limit=MAX_PAIRS)
    return V


def slices(motion: SelfMotion, T_root: np.ndarray, V: np.ndarray, limits: str = "respect"):
    """Every solution of each target at each of its values ``V`` (N, K): per target the solutions of
    all its values, in value order: (q (N, S, dof), parameter (N, S), count (N,), within_limits,
    singular, position_error, rotation_error (N, S), complete (N,), family, method)."""
    N, K = V.shape
    pair_t = np.repeat(np.arange(N), K)
    psi = V.reshape(-1)
    model, chain = motion.model, motion.chain
    inside = (psi >= motion.lower - LIMIT_TOLERANCE) & (psi <= motion.upper + LIMIT_TOLERANCE)
    solve = inside if limits == "respect" else np.ones(len(psi), bool)
    R = len(psi)
    sl = motion.solve(T_root[pair_t[solve]], psi[solve]) if solve.any() else None
    dof = model.dof
    if sl is None:
        rows, owner = np.zeros((0, dof)), np.zeros(0, np.intp)
        sing_rows = pe_rows = re_rows = np.zeros(0)
        complete_pairs = np.ones(R, bool)
        family, method = "", "analytic"
    else:
        idx = np.flatnonzero(solve)
        listed = np.arange(sl.q.shape[1])[None, :] < sl.count[:, None]
        if limits == "respect":
            sol_id = np.full(sl.q.shape[:2], -1)
            sol_id[listed] = np.arange(int(listed.sum()))
            others = np.arange(chain.n) != motion.k  # the parameter joint keeps its value: no copies of it
            rows, local = in_limit_copies(model, replace(chain, columns=chain.columns[others],
                                                         revolute=chain.revolute[others]), sl.q, sl.count)
            # which listed solution each copy came from: its pair and its rank in the pair (copies keep order)
            src = _copy_sources(sl.q, sl.count, rows, local, chain)
            flat = sol_id[local, src]
        else:
            rows, local = sl.q[listed], np.repeat(np.arange(len(sl.count)), sl.count)
            flat = np.arange(len(rows))
        owner = idx[local]
        sing_rows = sl.singular[listed][flat]
        pe_rows, re_rows = sl.position_error[listed][flat], sl.rotation_error[listed][flat]
        complete_pairs = np.ones(R, bool)
        complete_pairs[idx] = sl.complete
        family, method = sl.family, sl.method
    target = pair_t[owner]
    order = np.argsort(owner, kind="stable")  # target order, then value order, then the slice's order
    rows, owner, target = rows[order], owner[order], target[order]
    sing_rows, pe_rows, re_rows = (np.asarray(a)[order] for a in (sing_rows, pe_rows, re_rows))
    count = np.bincount(target, minlength=N).astype(np.int64)
    S = int(count.max(initial=0))
    q = np.full((N, S, dof), np.nan)
    param = np.full((N, S), np.nan)
    within = np.zeros((N, S), bool)
    singular = np.zeros((N, S), bool)
    pe, re = np.full((N, S), np.nan), np.full((N, S), np.nan)
    if len(rows):
        starts = np.concatenate([[0], np.cumsum(count)[:-1]])
        slot = np.arange(len(rows)) - starts[target]
        q[target, slot] = rows
        param[target, slot] = psi[owner]
        within[target, slot] = np.all((rows >= model.lower_limits - LIMIT_TOLERANCE)
                                      & (rows <= model.upper_limits + LIMIT_TOLERANCE), axis=1)
        singular[target, slot] = sing_rows
        pe[target, slot], re[target, slot] = pe_rows, re_rows
    complete = complete_pairs.reshape(N, K).all(axis=1)
    return q, param, count, within, singular, pe, re, complete, family, method


def _copy_sources(q, count, rows, local, chain) -> np.ndarray:
    """For each in-limit copy ``rows[i]`` of pair ``local[i]``: which of that pair's solutions it copies."""
    out = np.zeros(len(rows), np.intp)
    rev = chain.revolute
    cols = chain.columns
    for i in range(len(rows)):
        cand = q[local[i], :count[local[i]]][:, cols]
        d = np.abs(_wrapped(cand - rows[i, cols], rev)).max(axis=1)
        out[i] = int(np.argmin(d))
    return out
