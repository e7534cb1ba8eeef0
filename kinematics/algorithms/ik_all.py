"""Every inverse-kinematics solution of a link's pose: closed forms where the chain has a family,
a dense multistart search where it has none, each answer polished and checked on the real model.

For N targets ``T_world_link`` (or of a ``tool`` on the link), :func:`all_solutions`

1. folds the ``locked`` joints into the chain and names its family
   (:mod:`kinematics.algorithms.ik_families`);
2. finds **candidates**: the compiled closed form of the family (:mod:`kinematics.engine.ik_fast`, on the
   subproblems of :mod:`kinematics.engine.subproblems`,
   on the *ideal* chain for a robot near a family, e.g. a calibrated UR), the kernels of
   :mod:`kinematics.algorithms.ik_general` (a general 6R, a spherical wrist on a general arm, by the
   16-degree elimination; the planar and RPR short chains and Wen's Rhino arm in closed form), or --
   for a chain with no closed form (``method:
   "numeric"``, a 6-joint chain with a prismatic joint and no family, other short chains) -- damped Newton
   from ``SEARCH_SEEDS`` deterministic seeds spread over the joint space (a multistart search: it
   finds what its seeds reach, it does not prove that nothing is missed);
3. **polishes** every candidate with Newton steps on the real model's FK and Jacobian (the
   compiled kernels), so that a near-family chain's closed form lands on the real solution;
4. keeps only candidates whose FK (the FK kernel) is within the tolerances, merges duplicates
   (revolute angles compared modulo 2π, within ``DUPLICATE``);
5. applies the limits: ``"respect"`` lists every solution inside the limits, with each
   ``q + 2πk`` copy of a revolute joint that fits (a ±2π joint gives two or three copies of a
   branch); ``"ignore"`` lists each branch once, revolute angles in (−π, π];
6. flags each solution ``within_limits`` (the listed values) and ``singular`` (the smallest
   singular value of the free joints' 6 x n Jacobian below ``SINGULAR`` times the largest).

Unreachable targets have ``count`` 0. A near-family chain has its solution count checked against
the ideal chain's: where the polish found fewer, the elimination of the real 6R chain
(:mod:`kinematics.algorithms.ik_general`: every solution) joins in for that target, trusted where
it did not degenerate and found again every solution the polish had found; elsewhere the search
joins in, and ``complete`` is False where that still leaves fewer solutions than the ideal chain has.

The Puma 560 reaches a generic pose in eight ways:

>>> from kinematics.io import default_catalogue
>>> puma = default_catalogue().get("puma560_standard")
>>> T = compile_model(puma).fk(np.array([[0.2, 0.3, -0.4, 0.5, 0.6, 0.1]]), ["tool"])[:, 0]
>>> sol = all_solutions(puma, "tool", T, limits="ignore")
>>> sol.family.name, sol.method, int(sol.count[0]), bool(np.nanmax(sol.position_error) < 1e-12)
('spherical_wrist_parallel_23', 'analytic', 8, True)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from ..engine import ik_fast, ik_polish
from ..engine.parallel import run_rows
from ..engine.poe import PoEModel, compile_model
from ..errors import KinematicsError
from ..model.derived import PerModel
from ..model.robot import RobotModel
from ..spatial.transforms import inverse_transform
from ..tolerances import DEFAULT_POSITION_TOLERANCE, DEFAULT_ROTATION_TOLERANCE, LIMIT_TOLERANCE
from . import ik_general
from .ik import pose_errors
from .ik_families import Chain, Family, detect, reduce_chain, validate_locked
from .ik_kernels import kernel_of

LIMIT_POLICIES = ("respect", "ignore")
METHODS = ("auto", "analytic", "numeric")
#: Newton steps on the real model after the closed form (exact family, near family) and in the search
POLISH_STEPS, NEAR_STEPS, SEARCH_STEPS = 4, 60, 100
#: an exact family's candidate further than this (m + rad) from its target is the least-squares point of
#: a branch that does not exist (the closed form is the chain's own to 1e-9): it is not polished
EXACT_REACH = 1e-4
#: a near family's least-squares branch points are seeded this far (rad or m) on either side
NEAR_SPREAD = 0.05
#: seeds of the multistart search (per target)
SEARCH_SEEDS = 512
#: two solutions closer than this (rad or m, largest joint difference) are one
DUPLICATE = 1e-6
#: a listed solution's error above this (m + rad) gets up to FINAL_STEPS more Newton steps
TIGHT, FINAL_STEPS = 1e-12, 30
#: a squared pose error below this is converged (Newton stops for that row)
CONVERGED = 1e-28
#: targets per thread of the closed-form kernel at least
CLOSED_FORM_MIN_ROWS = 64
#: σ_min / σ_max of the Jacobian below this: a singular configuration
SINGULAR = 1e-7
#: a near family's polish is proven complete (:func:`_certified`) only with every solution this regular
#: (σ_min / σ_max) and this far from the others (rad or m)
CERTIFY_CONDITION, CERTIFY_SEPARATION = 1e-2, 1e-1
#: a listed solution the elimination did not find is a double root (two branches meeting) when the
#: Jacobian's σ_min / σ_max is below this (the elimination's near-double roots can come out complex)
DOUBLE_ROOT = 1e-5
#: a target with no solution whose closed-form candidates miss it by less than this many deviations of the
#: near family (m + rad) is at the edge of the reach: not proven complete (:func:`_near_miss`)
NEAR_MISS = 100.0


class Newton(NamedTuple):
    """How the compiled pass polishes a candidate: up to ``steps`` Levenberg-Marquardt steps from
    λ = ``lam0`` (``damped``: bounded steps, a search from seeds), ``middle`` undamped steps for a row
    that came near a solution, ``final`` more where it is near but not on it; a candidate whose first
    error (m + rad) is above ``reach`` is dropped unpolished."""

    steps: int
    lam0: float
    damped: bool
    middle: int
    final: int
    reach: float


#: an exact family's closed form; a near family's (and the elimination of its real chain); the
#: ik_general kernels' candidates; the multistart search
EXACT_PASS = Newton(POLISH_STEPS, 1e-12, False, 0, POLISH_STEPS, EXACT_REACH)
NEAR_PASS = Newton(NEAR_STEPS, 1e-12, False, 0, FINAL_STEPS, np.inf)
GENERAL_PASS = Newton(POLISH_STEPS, 1e-12, False, 0, POLISH_STEPS, np.inf)
SEARCH_PASS = Newton(SEARCH_STEPS, 1e-2, True, 6 * POLISH_STEPS, FINAL_STEPS, np.inf)


@dataclass(frozen=True, eq=False)
class SolutionArrays:
    """The solutions of N targets, padded to the largest count K.

    q: (N, K, dof), NaN in padding; count: (N,); within_limits, singular: (N, K) bool (False in
    padding); position_error (metres), rotation_error (radians): (N, K), NaN in padding;
    complete: (N,) False where a near-family target left to the search has fewer solutions than the ideal chain.
    """

    q: np.ndarray
    count: np.ndarray
    within_limits: np.ndarray
    singular: np.ndarray
    position_error: np.ndarray
    rotation_error: np.ndarray
    complete: np.ndarray

    def solutions(self, n: int = 0) -> list[dict[str, Any]]:
        """The solutions of target ``n`` as records ``{q, position_error, rotation_error, within_limits, singular}``."""
        return [{"q": self.q[n, k].tolist(), "position_error": float(self.position_error[n, k]),
                 "rotation_error": float(self.rotation_error[n, k]), "within_limits": bool(self.within_limits[n, k]),
                 "singular": bool(self.singular[n, k])} for k in range(int(self.count[n]))]


@dataclass(frozen=True, eq=False)
class AllSolutions(SolutionArrays):
    """Every solution of N targets (the arrays of :class:`SolutionArrays`): family, the chain's
    :class:`~kinematics.algorithms.ik_families.Family`; method, ``"analytic"`` or ``"search"``."""

    family: Family
    method: str


def _errors6(F: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """(K, 6): position error and rotation vector of ``R_target Rᵀ`` (world axes), compiled row by row."""
    e = np.empty((F.shape[0], 6))
    ik_fast.pose_error_rows(np.ascontiguousarray(F), np.ascontiguousarray(targets), e)
    return e


def newton(poe: PoEModel, link: str, Q: np.ndarray, targets: np.ndarray, columns: np.ndarray, steps: int,
           tool: np.ndarray | None = None, position_only: bool = False, damped: bool = False) -> np.ndarray:
    """``steps`` Levenberg-Marquardt steps moving the ``columns`` of ``Q`` (K, dof) towards ``targets``
    (K, 4, 4); returns the new Q (K, dof).

    Each row keeps its own damping λ: a step that lowers the squared error is taken and λ falls
    (/4, down to 1e-15: pure Newton, quadratic convergence), a step that does not is refused and λ
    rises (x8). ``damped`` starts from λ = 1e-2 (far from a solution) instead of 1e-12, and bounds
    every step to 0.5 rad (or m) per joint.
    """
    Q = np.array(Q, dtype=float)
    rows = slice(0, 3) if position_only else slice(0, 6)
    n = len(columns)
    K = len(Q)
    if K == 0:
        return Q
    lam = np.full(K, 1e-2 if damped else 1e-12)

    def error(Qm, Tm=targets):
        e = _errors6(poe.fk(Qm, [link], tool=tool)[:, 0], Tm)[:, rows]
        return e, np.sum(e * e, axis=1)

    e, cost = error(Q)
    active = np.flatnonzero(cost > CONVERGED)
    for _ in range(steps):
        if active.size == 0:
            break
        # a row leaves once converged, so its steps do not depend on the other rows of the batch
        Qa, ea = Q[active], e[active]
        J = poe.jacobian(Qa, link, "local_world_aligned", tool=tool)[:, rows][:, :, columns]
        # the normal equations row by row (compiled): the same arithmetic for a row alone and in a batch
        dq = np.empty((len(active), n))
        ik_fast.damped_steps(np.ascontiguousarray(J), np.ascontiguousarray(ea), np.ascontiguousarray(lam[active]), dq)
        if damped:
            big = np.abs(dq).max(axis=1, initial=0.0)
            dq *= np.minimum(1.0, 0.5 / np.maximum(big, 1e-300))[:, None]
        trial = Qa.copy()
        trial[:, columns] += dq
        e2, cost2 = error(trial, targets[active])
        better = cost2 < cost[active]
        took = active[better]
        Q[took], e[took], cost[took] = trial[better], e2[better], cost2[better]
        lam[active] = np.where(better, np.maximum(lam[active] / 4.0, 1e-15), np.minimum(lam[active] * 8.0, 1e6))
        # a row leaves once converged, or once stuck (its damping at the ceiling: no step lowers its error)
        active = active[(cost[active] > CONVERGED) & (lam[active] < 1e6)]
    return Q


def _halton(n: int, dim: int) -> np.ndarray:
    """The first n points (n, dim) of the Halton sequence in [0, 1)^dim (bases: the first primes)."""
    primes = [2, 3, 5, 7, 11, 13, 17, 19, 23, 29][:dim]
    out = np.empty((n, dim))
    for d, b in enumerate(primes):
        for i in range(n):
            f, x, k = 1.0, 0.0, i + 1
            while k > 0:
                f /= b
                x += f * (k % b)
                k //= b
            out[i, d] = x
    return out


def _search_seeds(model: RobotModel, chain: Chain, count: int) -> np.ndarray:
    """(count, n) seeds of the chain's free joints: revolute over (−π, π], prismatic over its limits."""
    u = _halton(count, chain.n)
    lo = np.where(chain.revolute, -np.pi, model.lower_limits[chain.columns])
    hi = np.where(chain.revolute, np.pi, model.upper_limits[chain.columns])
    lo = np.where(np.isfinite(lo), lo, -1.0)
    hi = np.where(np.isfinite(hi), hi, 1.0)
    return lo + u * (hi - lo)


def _wrap_revolute(model: RobotModel, chain: Chain, q: np.ndarray) -> np.ndarray:
    q = q.copy()
    cols = chain.columns[chain.revolute]
    w = np.mod(q[..., cols] + np.pi, 2 * np.pi) - np.pi
    q[..., cols] = np.where(w <= -np.pi + 1e-15, np.pi, w)
    return q


def _copies(model: RobotModel, chain: Chain, q: np.ndarray) -> list[np.ndarray]:
    """Every q + 2πk copy (revolute joints with limits) within the limits; [] when none fits."""
    options = []
    lo, hi = model.lower_limits, model.upper_limits
    cont = model.continuous
    for c, rev in zip(chain.columns, chain.revolute):
        v = q[c]
        if rev and not cont[c] and np.isfinite(lo[c]) and np.isfinite(hi[c]):
            k0 = int(np.ceil((lo[c] - LIMIT_TOLERANCE - v) / (2 * np.pi)))
            k1 = int(np.floor((hi[c] + LIMIT_TOLERANCE - v) / (2 * np.pi)))
            vals = [min(max(v + 2 * np.pi * k, lo[c]), hi[c]) for k in range(k0, k1 + 1)]
        else:
            vals = [v] if (lo[c] - LIMIT_TOLERANCE <= v <= hi[c] + LIMIT_TOLERANCE) else []
            vals = [min(max(x, lo[c]), hi[c]) for x in vals]
        if not vals:
            return []
        options.append(vals)
    out = [q.copy()]
    for c, vals in zip(chain.columns, options):
        nxt = []
        for base in out:
            for v in vals:
                b = base.copy(); b[c] = v; nxt.append(b)
        out = nxt
    return out


#: (chain, family) of the last ``FAMILY_CACHE`` (link, locked, tool) asked of a model
_families = PerModel(lambda model: {})
FAMILY_CACHE = 64


def _chain_family(model: RobotModel, link: str, locked: dict | None,
                  tool: np.ndarray | None) -> tuple[Chain, Family, tuple]:
    """:func:`reduce_chain`, :func:`detect` and the chain as the compiled pass takes it (``h, r,
    revolute, M`` and :func:`~kinematics.engine.ik_polish.lane_table`'s form), kept per model
    (``locked`` validated every time)."""
    values = validate_locked(model, locked)
    key = (link, tuple(sorted(values.items())), None if tool is None else np.asarray(tool, dtype=float).tobytes())
    cache = _families(model)
    hit = cache.get(key)
    if hit is None:
        chain = reduce_chain(model, link, values, tool)
        if not chain.joints:  # nothing to solve (the callers refuse it): no family, not kept
            return chain, None, None
        hit = (chain, detect(chain), ik_polish.chain_arguments(chain.columns, chain.h, chain.r, chain.revolute,
                                                               chain.M))
        if len(cache) >= FAMILY_CACHE:
            cache.clear()
        cache[key] = hit
    return hit


@dataclass(frozen=True, slots=True)
class _Problem:
    """One call of :func:`all_solutions` as its steps share it: the model and its compiled form, the
    link (and ``tool``), the reduced ``chain``, its family and the chain as the compiled pass takes it
    (``real``), the targets in the root frame ``T_root`` (N, 4, 4), each target's configuration off the
    chain ``base_q`` (N, dof), and how the solutions are judged (``mode``, ``tolerances`` (position,
    rotation), ``search_seeds`` of the multistart search, ``locked`` joints)."""

    model: RobotModel
    poe: PoEModel
    link: str
    tool: np.ndarray | None
    chain: Chain
    fam: Family
    real: tuple
    T_root: np.ndarray
    base_q: np.ndarray
    locked: dict | None
    mode: str
    tolerances: tuple[float, float]
    search_seeds: int

    @property
    def position_only(self) -> bool:
        return self.mode == "position"

    @property
    def N(self) -> int:
        return len(self.T_root)

    def errors(self, Q: np.ndarray, targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(position, rotation) errors of the rows ``Q`` (R, dof) at ``targets`` (R, 4, 4)."""
        return pose_errors(self.poe.fk(Q, [self.link], tool=self.tool)[:, 0], targets)

    def newton(self, Q: np.ndarray, targets: np.ndarray, steps: int, damped: bool) -> np.ndarray:
        """:func:`newton` on the chain's joints of the rows ``Q`` at ``targets``."""
        return newton(self.poe, self.link, Q, targets, self.chain.columns, steps, self.tool, self.position_only, damped)

    def near_enough(self, p: np.ndarray, r: np.ndarray) -> np.ndarray:
        """Rows not yet on a solution (``p``, ``r`` above :data:`TIGHT`) but within ten times the
        tolerances: more Newton steps may land them."""
        tp, tr = self.tolerances
        po = self.position_only
        return np.isfinite(p) & (p + np.where(po, 0.0, r) > TIGHT) & (p < 10 * tp) & (po | (r < 10 * tr))


def chain_family(model: RobotModel, link: str, locked: dict | None = None,
                 tool: np.ndarray | None = None) -> tuple[Chain, Family]:
    """``(reduce_chain(...), detect(...))`` of the chain to ``link`` with ``locked`` joints held (and
    ``tool``), kept per model as :func:`all_solutions` keeps them (a request's checks and its solving
    detect the family once)."""
    chain, fam, _ = _chain_family(model, link, locked, tool)
    return chain, fam


def all_solutions(model: RobotModel, link: str, targets: np.ndarray, *, base: np.ndarray | None = None,
                  tool: np.ndarray | None = None, locked: dict | None = None, limits: str = "respect",
                  method: str = "auto", seed: np.ndarray | None = None, mode: str = "pose",
                  position_tolerance: float = DEFAULT_POSITION_TOLERANCE,
                  rotation_tolerance: float = DEFAULT_ROTATION_TOLERANCE,
                  search_seeds: int = SEARCH_SEEDS) -> AllSolutions:
    """Every solution putting ``link`` (or ``tool`` on it) at ``targets`` (N, 4, 4), root frame
    unless ``base`` (``T_world_root``, (4, 4) or (N, 4, 4)) is given. ``seed`` (dof,) or (N, dof):
    solutions nearest it first, and the values of joints off the chain. See the module text."""
    if limits not in LIMIT_POLICIES:
        raise KinematicsError(f"limits: {limits!r} is not one of {', '.join(LIMIT_POLICIES)}")
    if method not in METHODS:
        raise KinematicsError(f"method: {method!r} is not one of {', '.join(METHODS)}")
    chain, fam, real = _chain_family(model, link, locked, tool)
    if fam is None:
        raise KinematicsError(f"the chain to {link} has no joint left to move (every one locked, or none on the way)")
    if fam.name == "redundant":
        raise KinematicsError(f"the chain to {link} has {chain.n} free joints: its solutions are infinitely many; "
                              f"lock {chain.n - 6} of them (locked)")
    position_only = mode == "position"
    # (a short chain's closed form solves a pose; of a position alone, only the 2R's)
    kernel = kernel_of(fam)
    short_position = position_only and kernel is not None and not kernel.compiled and not kernel.position
    if method == "analytic" and (not fam.closed_form or short_position):
        raise KinematicsError(f"method: 'analytic': the chain to {link} ({fam.name}) has no closed form here; "
                              "use 'auto' or 'numeric'")
    if position_only and chain.n > 3:
        raise KinematicsError(f"mode: 'position' with solutions 'all': the chain to {link} has {chain.n} free joints, "
                              "so a position alone has infinitely many solutions; give a pose, or lock joints")
    # a family's kernel: its closed form, the elimination, or (the fallback of a spherical wrist on a
    # general arm) the bracketing search
    use_closed = kernel is not None and method != "numeric" and (not position_only or kernel.position)
    targets = np.asarray(targets, dtype=float).reshape(-1, 4, 4)
    N = targets.shape[0]
    base_q = np.zeros((N, model.dof))
    if seed is not None:
        base_q[:] = np.broadcast_to(np.asarray(seed, dtype=float), (N, model.dof))
    for name, v in chain.locked.items():
        base_q[:, model.q_index[name]] = v
    s = _Problem(model, compile_model(model), link, tool, chain, fam, real,
                 targets if base is None else np.matmul(inverse_transform(base), targets), base_q, locked, mode,
                 (position_tolerance, rotation_tolerance), search_seeds)
    degenerate = np.zeros(0, dtype=np.intp)
    general = kernel is not None and not kernel.compiled
    if use_closed:
        if general and position_only:  # a 2R's position (numpy)
            cand, counts = ik_general.family_candidates(fam, s.T_root, position_only)
            rows, owner, errors = _polish_candidates(s, cand, np.maximum(counts, 0))
        else:
            if general:  # the general 6R elimination, the short chains' closed forms, then the compiled pass
                cand, counts = ik_general.family_candidates(fam, s.T_root, position_only)
                degenerate = np.flatnonzero(counts < 0)  # the elimination degenerates there: the search joins in
                Qk, found, pe, re, within, sing = _compiled_pass(
                    s, np.ascontiguousarray(cand), np.maximum(counts, 0), False, GENERAL_PASS)
                nominal = None
            else:  # candidates, polish, check, duplicates and flags in one compiled pass per target
                Qk, found, pe, re, within, sing, nominal, seeds = _closed_form_solutions(s)
            if fam.near and not general:
                # a near family: proven by the perturbation bound (:func:`_certified`), else checked below
                short = np.flatnonzero(~_certified(s, Qk, found, nominal))
            else:
                short = np.zeros(0, dtype=np.intp)
            if not (short.size or degenerate.size) and limits == "ignore" and seed is None:
                K = int(found.max(initial=0))
                return AllSolutions(Qk[:, :K], found, within[:, :K], sing[:, :K] == 1, pe[:, :K], re[:, :K],
                                    np.ones(N, bool), fam, "analytic" if fam.closed_form else "search")
            slot = np.arange(Qk.shape[1])[None, :] < found[:, None]
            rows, owner, errors = Qk[slot], np.repeat(np.arange(N), found), (pe[slot], re[slot])
    else:
        rows, owner, errors = _search(s)
    complete = np.ones(N, bool)
    if use_closed and degenerate.size:
        rows, owner = _join_search(s, degenerate, rows, owner)
        errors = None
    if use_closed and fam.near and not general:
        # a near family: where the perturbation bound does not prove the polish complete (fewer
        # solutions than the family's most, a branch lost by a singularity or the edge of the reach),
        # the elimination of the real chain (every solution) joins in for that target; where it cannot
        # apply or is not to be trusted, the search, and the target is not claimed complete
        complete = np.ones(N, bool)
        if short.size:
            rows, owner, proven = _join_elimination(s, short, rows, owner)
            proven &= ~_near_miss(s, seeds, short, rows, owner)
            rest = short[~proven]
            if rest.size:
                rows, owner = _join_search(s, rest, rows, owner)
            complete[rest] = False
            errors = None
    if limits == "respect":
        rows, owner = all_copies(model, chain, rows, owner)
        errors = None
    if seed is not None and len(rows):
        order = np.lexsort((np.abs(rows - base_q[owner]).sum(axis=1), owner))  # by target, then nearest the seed
        rows, owner = rows[order], owner[order]
        errors = None if errors is None else (errors[0][order], errors[1][order])
    return _pack(s, rows, owner, "analytic" if use_closed and fam.closed_form else "search", complete, errors)


def _certified(s: _Problem, Qk, found, nominal) -> np.ndarray:
    """(N,) True where a near family's polished solutions are proven to be every solution of the real chain.

    The bound argument: the real chain's FK differs from the ideal chain's by at most about the
    family's ``deviation`` everywhere, so a real solution is a configuration where the ideal chain
    misses the target by that much at most: near an ideal solution (where the ideal Jacobian is
    regular), or near a fold of the ideal chain (a branch point, a least-squares point of its closed
    form, where two ideal solutions appear or vanish) within that distance of the target. Where the
    ideal chain has the family's **most** solutions (every subproblem with both roots), no fold can
    add two more within that distance, so every real solution continues one ideal solution; the polish
    found one real solution per ideal one (``found == nominal``), each regular (σ_min / σ_max of the
    Jacobian at least :data:`CERTIFY_CONDITION`) and the solutions far apart compared with the
    deviation (at least :data:`CERTIFY_SEPARATION`, rad or m), so no two ideal solutions led to
    one real solution while another was missed. Anything else (fewer ideal solutions, a solution near
    a singularity or near another) is left to the elimination of the real chain."""
    poe, link, tool, chain, fam = s.poe, s.link, s.tool, s.chain, s.fam
    ok = (nominal == fam.max_solutions) & (found == nominal)
    idx = np.flatnonzero(ok)
    if not idx.size:
        return ok
    K = int(found[idx].max())
    X = Qk[idx, :K]
    cols, rev = chain.columns, chain.revolute
    J = poe.jacobian(X.reshape(-1, X.shape[-1]), link, "local_world_aligned", tool=tool)[:, :, cols]
    sv = np.linalg.svd(J, compute_uv=False).reshape(len(idx), K, -1)
    regular = np.all(sv[..., -1] >= CERTIFY_CONDITION * sv[..., 0], axis=1)
    d = X[:, :, None, cols] - X[:, None, :, cols]
    d = np.abs(np.where(rev, np.mod(d + np.pi, 2 * np.pi) - np.pi, d)).max(axis=-1)
    d[:, np.arange(K), np.arange(K)] = np.inf
    ok[idx] = regular & (d.min(axis=(1, 2)) >= CERTIFY_SEPARATION)
    return ok


def _near_miss(s: _Problem, seeds, targets, rows, owner) -> np.ndarray:
    """(len(targets),) True where no solution is listed but a closed-form candidate (``seeds``: the
    candidates and their counts) misses the target by less than :data:`NEAR_MISS` times the family's
    deviation (m + rad, on the real model): the edge of the reach, where a branch may exist that
    the elimination (degenerate at a double root) did not give; such a target is not proven."""
    poe, link, tool, chain, fam, T_root, base_q = s.poe, s.link, s.tool, s.chain, s.fam, s.T_root, s.base_q
    cand, ccount = seeds
    out = np.zeros(len(targets), bool)
    listed = np.bincount(owner, minlength=len(T_root))[targets]
    empty = np.flatnonzero((listed == 0) & (ccount[targets] > 0))
    if not empty.size:
        return out
    t = targets[empty]
    X = np.concatenate([cand[n, :ccount[n]] for n in t])
    who = np.repeat(np.arange(len(t)), ccount[t])
    Q = base_q[t[who]].copy()
    Q[:, chain.columns] = -X[:, ::-1] if fam.reversed else X
    p, r = pose_errors(poe.fk(Q, [link], tool=tool)[:, 0], T_root[t[who]])
    miss = np.full(len(t), np.inf)
    np.minimum.at(miss, who, p + r)
    out[empty] = miss < NEAR_MISS * max(fam.deviation, DUPLICATE)
    return out


def _join_search(s: _Problem, targets: np.ndarray, rows: np.ndarray, owner: np.ndarray):
    """``rows``, ``owner`` with the multistart search's solutions of the ``targets`` (indices) merged in."""
    extra = all_solutions(s.model, s.link, s.T_root[targets], tool=s.tool, locked=s.locked, limits="ignore",
                          method="numeric", mode=s.mode, position_tolerance=s.tolerances[0],
                          rotation_tolerance=s.tolerances[1], search_seeds=s.search_seeds)
    more = [_with_free(s.base_q[n], s.chain, extra.q[i, :extra.count[i]]) for i, n in enumerate(targets)]
    return _merge(s.chain, s.N, rows, owner, targets, more)


def _join_elimination(s: _Problem, targets: np.ndarray, rows: np.ndarray, owner: np.ndarray):
    """``rows``, ``owner`` with the solutions of the ``targets`` (indices) by the 16-degree elimination
    of the real chain (:mod:`.ik_general`, every solution) merged in, and a mask (len(targets),) of the
    targets it solved (False: it degenerates there, or does not apply to the chain)."""
    chain = s.chain
    proven = np.zeros(len(targets), bool)
    cols, rev = np.ascontiguousarray(chain.columns, dtype=np.intp), np.ascontiguousarray(chain.revolute)
    for loop in () if s.position_only else _elimination_chains(chain):
        todo = np.flatnonzero(~proven)
        if not todo.size:
            break
        reverse = loop is not chain
        at = targets[todo]
        goals = inverse_transform(s.T_root[at]) if reverse else s.T_root[at]
        cand, counts = ik_general.general_6r_candidates(loop, goals)
        # (near a branch point the elimination's roots are less accurate: the near family's Newton budget)
        Qk, found, *_ = _compiled_pass(s, np.ascontiguousarray(cand), np.maximum(counts, 0), reverse, NEAR_PASS,
                                       rows_of=at)
        more = [Qk[i, :found[i]] for i in range(len(at))]
        # trusted where it did not degenerate and found again every solution listed so far but double roots
        # (where it misses a regular one, its roots are not to be trusted there: the other way round, else
        # the search); a double root, where two branches meet, is a near-real complex pair of its roots
        for i, n in enumerate(at):
            missed = [q for q in rows[owner == n]
                      if not any(ik_polish.close_rows(q, m, cols, rev, DUPLICATE) for m in more[i])]
            proven[todo[i]] = counts[i] >= 0 and (not missed or bool(_double_roots(s, np.array(missed)).all()))
        rows, owner = _merge(chain, s.N, rows, owner, at, more)
    return rows, owner, proven


def _double_roots(s: _Problem, Q) -> np.ndarray:
    """(K,) True where the chain's Jacobian at ``Q`` (K, dof) is singular to :data:`DOUBLE_ROOT`
    (σ_min / σ_max): two solutions meeting there."""
    chain = s.chain
    J = s.poe.jacobian(Q, chain.link, "local_world_aligned")[:, :, chain.columns]
    sv = np.linalg.svd(J, compute_uv=False)
    return sv[:, -1] <= DOUBLE_ROOT * sv[:, 0]


#: the chains the elimination runs on, per chain (itself and its reversed chain, those it applies to)
_loops: dict[int, tuple] = {}


def _elimination_chains(chain: Chain) -> tuple:
    """The chain itself and its reversed chain, those the elimination applies to
    (:func:`.ik_general.applies`; a lock value can make the loop degenerate one way and not the
    other: the xArm7 with joint6 locked), kept per chain object."""
    hit = _loops.get(id(chain))
    if hit is None or hit[0] is not chain:
        loops = tuple(c for c in (chain, chain.reversed()) if ik_general.applies(c))
        if len(_loops) > FAMILY_CACHE:
            _loops.clear()
        hit = _loops[id(chain)] = (chain, loops)
    return hit[1]


def _merge(chain, N, rows, owner, targets, more):
    """``rows`` (R, dof), ``owner`` (R,) of N targets with the rows ``more[i]`` of target ``targets[i]``
    added, each solution of a target once (in target order)."""
    per = [rows[owner == n] for n in range(N)]
    for i, n in enumerate(targets):
        per[n] = np.concatenate([per[n], more[i]])
    owner = np.concatenate([np.full(len(r), n, dtype=np.intp) for n, r in enumerate(per)]) if N else owner
    rows = np.concatenate(per) if N else rows
    starts = np.concatenate([[0], np.cumsum([len(r) for r in per])]).astype(np.intp)
    keep = np.zeros(len(rows), bool)
    ik_fast.distinct_rows(rows, np.ones(len(rows), bool), starts, chain.columns, chain.revolute, DUPLICATE, keep)
    return rows[keep], owner[keep]


def _search(s: _Problem):
    """The multistart search: rows (R, dof), owner (R,) and their (position, rotation) errors."""
    model, chain, N = s.model, s.chain, s.N
    seeds = _search_seeds(model, chain, s.search_seeds)
    if not s.position_only and not chain.mimic:
        return _search_compiled(s, seeds)
    owner = np.repeat(np.arange(N), len(seeds))
    Q = s.base_q[owner].copy()
    Q[:, chain.columns] = np.tile(seeds, (N, 1))
    Tt = s.T_root[owner]
    if not len(Q):
        return Q, owner, None
    Q = s.newton(Q, Tt, SEARCH_STEPS, True)
    # then undamped steps on the rows that came near a solution: quadratic convergence onto it
    e = _errors6(s.poe.fk(Q, [s.link], tool=s.tool)[:, 0], Tt)
    near = np.flatnonzero(np.linalg.norm(e[:, :3] if s.position_only else e, axis=1) < 1e-2)
    Q[near] = s.newton(Q[near], Tt[near], 6 * POLISH_STEPS, False)
    Q = _wrap_revolute(model, chain, Q)
    ok = np.all(np.isfinite(Q), axis=1)
    p, r = s.errors(np.where(ok[:, None], Q, 0.0), Tt)
    # rows near a solution but not on it to machine precision (a double root where two branches
    # meet converges only linearly): more Newton steps before the check
    slow = np.flatnonzero(s.near_enough(p, r))
    if slow.size:
        Q[slow] = _wrap_revolute(model, chain, s.newton(Q[slow], Tt[slow], FINAL_STEPS, False))
        p[slow], r[slow] = s.errors(Q[slow], Tt[slow])
    return _accepted(s, Q, owner, np.full(N, len(seeds)), ok, p, r)


def _search_compiled(s: _Problem, seeds: np.ndarray):
    """The multistart search of a pose in :func:`kinematics.engine.ik_polish.polish` (damped LM from
    every seed, then undamped steps near a solution), targets on the engine's threads."""
    N, S = s.N, len(seeds)
    cand = np.broadcast_to(np.ascontiguousarray(seeds), (N, S, s.chain.n))
    Qk, found, pe, re, within, sing = _compiled_pass(s, cand, np.full(N, S, dtype=np.int64), False, SEARCH_PASS,
                                                     min_rows=1, piece_rows=1)
    slot = np.arange(S)[None, :] < found[:, None]
    return Qk[slot], np.repeat(np.arange(N), found), (pe[slot], re[slot])


def _compiled_pass(s: _Problem, cand, ccount, reversed_, newton: Newton, *, rows_of=None, before=None, after=None,
                   min_rows=CLOSED_FORM_MIN_ROWS, piece_rows=None):
    """:func:`kinematics.engine.ik_polish.polish` of the candidates ``cand`` (N, C, n), ``ccount`` (N,)
    of the problem's targets (or of its targets ``rows_of``, indices) over the engine's threads:
    ``newton``, how it polishes. ``before(a, b)`` and ``after(a, b)`` run on the same thread before
    and after each row range (a family's kernel writing the candidates, a near family's reference
    count). Returns q (N, C, dof) NaN-padded, count (N,), position and rotation errors (N, C),
    within_limits (N, C), singular (N, C: 1 singular, 0 regular)."""
    model = s.model
    T_root = s.T_root if rows_of is None else s.T_root[rows_of]
    base_q = s.base_q if rows_of is None else s.base_q[rows_of]
    N, C, dof = cand.shape[0], cand.shape[1], model.dof
    Qk = np.empty((N, C, dof))
    found = np.zeros(N, dtype=np.int64)
    pe, re = np.empty((N, C)), np.empty((N, C))
    within = np.zeros((N, C), bool)
    sing = np.zeros((N, C), np.int8)
    T_root = np.ascontiguousarray(T_root)
    limits = (np.ascontiguousarray(model.lower_limits), np.ascontiguousarray(model.upper_limits), LIMIT_TOLERANCE)
    settings = ik_polish.polish_settings(newton.steps, newton.lam0, newton.damped, newton.middle, TIGHT, newton.final,
                                         newton.reach, *s.tolerances, DUPLICATE, SINGULAR)
    outputs = (Qk, found, pe, re, within, sing)

    def rows(a: int, b: int) -> None:  # nogil kernels over targets a..b, on the engine's threads
        if before is not None:
            before(a, b)
        ik_polish.polish(cand, ccount, reversed_, T_root, base_q, s.real, settings, limits, a, b, outputs)
        if after is not None:
            after(a, b)

    run_rows(rows, N, min_rows=min_rows, piece_rows=piece_rows)
    return Qk, found, pe, re, within, sing


def _closed_form_solutions(s: _Problem):
    """Every solution by the family's compiled kernel (:mod:`.ik_kernels`) and :func:`_compiled_pass`:
    the arrays of :func:`_compiled_pass` and the ideal chain's counts (N,; a near family, else None)."""
    fam = s.fam
    ideal = fam.ideal
    goals = inverse_transform(s.T_root) if fam.reversed else s.T_root
    # row by row (not a batched BLAS product): a target alone gets its batch answer
    G = np.ascontiguousarray(np.einsum("nij,jk->nik", goals, inverse_transform(ideal.M)))
    kernel = kernel_of(fam)
    C = kernel.candidates
    write = kernel.bind(fam)
    N = G.shape[0]
    cand = np.empty((N, C, 6))
    ccount = np.zeros(N, dtype=np.int64)
    flag = np.zeros((N, C), dtype=np.int64)
    nominal = np.zeros(N, dtype=np.int64) if fam.near else None
    cand0 = np.empty((N, C, 6)) if fam.near else None
    count0 = np.zeros(N, dtype=np.int64)
    goals = np.ascontiguousarray(goals)
    ideal_chain = tuple(np.ascontiguousarray(a) for a in (ideal.h, ideal.r, ideal.revolute, ideal.M))

    def candidates(a, b, width, out, n):
        write(G[a:b], width, out[a:b], n[a:b], flag[a:b])

    def reference(a, b):  # a near family: the ideal chain's own count
        candidates(a, b, 0.0, cand0, count0)
        ik_polish.nominal(cand0, count0, goals, ideal_chain, (*s.tolerances, DUPLICATE), a, b, nominal)

    out = _compiled_pass(s, cand, ccount, fam.reversed, NEAR_PASS if fam.near else EXACT_PASS,
                         before=lambda a, b: candidates(a, b, NEAR_SPREAD if fam.near else 0.0, cand, ccount),
                         after=reference if fam.near else None)
    return out + (nominal, (cand, ccount))


def all_copies(model: RobotModel, chain: Chain, rows: np.ndarray, owner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every ``q + 2πk`` copy within the limits of each row (R, dof) (:func:`_copies`, compiled):
    the copies (R', dof) and their targets (R',)."""
    rows = np.ascontiguousarray(rows, dtype=float).reshape(-1, model.dof)
    cols = np.ascontiguousarray(chain.columns, dtype=np.intp)
    lo, hi = np.ascontiguousarray(model.lower_limits), np.ascontiguousarray(model.upper_limits)
    periodic = np.ascontiguousarray(chain.revolute & ~model.continuous[cols] & np.isfinite(lo[cols])
                                    & np.isfinite(hi[cols]))
    starts = np.zeros(len(rows) + 1, dtype=np.int64)
    out = np.empty((0, model.dof))
    ik_polish.copies(rows, cols, periodic, lo, hi, LIMIT_TOLERANCE, True, starts, out)
    per = starts[1:].copy()
    np.cumsum(starts, out=starts)
    out = np.empty((int(starts[-1]), model.dof))
    ik_polish.copies(rows, cols, periodic, lo, hi, LIMIT_TOLERANCE, False, starts, out)
    return out, np.repeat(np.asarray(owner, dtype=np.intp), per)


def _polish_candidates(s: _Problem, cand: np.ndarray, counts: np.ndarray):
    """Closed-form candidates (N, C, n) with their counts (N,), measured, Newton-polished where not yet
    on a solution, checked against the tolerance and merged: rows (R, dof), owner (R,) and their
    (position, rotation) errors (the numpy path of :mod:`.ik_general`'s families)."""
    model, chain, N = s.model, s.chain, s.N
    owner = np.repeat(np.arange(N), counts)
    Q = s.base_q[owner].copy()
    Q[:, chain.columns] = np.concatenate([cand[n, :counts[n]] for n in range(N)]) if N else np.zeros((0, chain.n))
    Tt = s.T_root[owner]
    if not len(Q):
        return Q, owner, None
    Q = _wrap_revolute(model, chain, Q)
    ok = np.all(np.isfinite(Q), axis=1)
    p, r = s.errors(np.where(ok[:, None], Q, 0.0), Tt)
    todo = np.flatnonzero(ok & ~((p <= TIGHT) & (r <= TIGHT)))  # most candidates are on a solution already
    for steps in (POLISH_STEPS, POLISH_STEPS):  # a few steps, then a few more where a double root converges slowly
        if not todo.size:
            break
        Q[todo] = _wrap_revolute(model, chain, s.newton(Q[todo], Tt[todo], steps, False))
        ok[todo] = np.all(np.isfinite(Q[todo]), axis=1)
        p[todo], r[todo] = s.errors(np.where(ok[todo, None], Q[todo], 0.0), Tt[todo])
        todo = todo[s.near_enough(p[todo], r[todo])]
    return _accepted(s, Q, owner, counts, ok, p, r)


def _accepted(s: _Problem, Q, owner, counts, ok, p, r):
    """The rows of ``Q`` (``counts`` per target, in target order) that are finite (``ok``) and within the
    tolerances, each solution of a target once: rows, owner and their (position, rotation) errors."""
    tp, tr = s.tolerances
    ok &= (p <= tp) & (s.position_only | (r <= tr))
    starts = np.concatenate([[0], np.cumsum(counts)]).astype(np.intp)
    keep = np.zeros(len(Q), bool)
    ik_fast.distinct_rows(Q, ok, starts, s.chain.columns, s.chain.revolute, DUPLICATE, keep)
    return Q[keep], owner[keep], (p[keep], r[keep])


def _with_free(base: np.ndarray, chain: Chain, Q: np.ndarray) -> np.ndarray:
    """Rows of ``Q`` (K, dof) with the joints off the chain taken from ``base`` (dof,)."""
    out = np.repeat(base[None], len(Q), 0)
    out[:, chain.columns] = Q[:, chain.columns]
    return out


def _singular(J: np.ndarray) -> np.ndarray:
    """σ_min / σ_max of each J (R, m, n), m >= n, at most :data:`SINGULAR`. A square J whose
    ``|det J| / ‖J‖_F^n`` (a lower bound of σ_min / σ_max) is above the threshold is regular without
    more work; the others get the eigenvalues of ``JᵀJ``."""
    out = np.zeros(len(J), bool)
    todo = np.arange(len(J))
    if J.shape[1] == J.shape[2]:
        F = np.linalg.norm(J, axis=(1, 2))
        bound = np.abs(np.linalg.det(J)) / np.maximum(F, 1e-300) ** J.shape[2]
        todo = np.flatnonzero(~(bound > SINGULAR))
    if todo.size:
        lam = np.linalg.eigvalsh(np.einsum("nri,nrj->nij", J[todo], J[todo]))
        out[todo] = lam[:, 0] <= (SINGULAR ** 2) * np.maximum(lam[:, -1], 1e-300)
    return out


def _pack(s: _Problem, rows, owner, method, complete, errors=None) -> AllSolutions:
    """The padded (N, K, ...) arrays of the solutions ``rows`` (R, dof) of targets ``owner`` (R,), sorted by target
    (``errors``: their (position, rotation) errors if known)."""
    model, chain, N, dof = s.model, s.chain, s.N, s.model.dof
    count = np.bincount(owner, minlength=N).astype(np.int64) if len(rows) else np.zeros(N, np.int64)
    K = int(count.max(initial=0))
    q = np.full((N, K, dof), np.nan)
    within = np.zeros((N, K), bool)
    singular = np.zeros((N, K), bool)
    pe = np.full((N, K), np.nan)
    re = np.full((N, K), np.nan)
    if len(rows):
        p, r = errors if errors is not None else s.errors(rows, s.T_root[owner])
        J = s.poe.jacobian(rows, s.link, "local_world_aligned", tool=s.tool)[:, :, chain.columns]
        if s.position_only:
            J = J[:, :3]
        sing = _singular(J) if J.shape[1] >= chain.n else np.ones(len(rows), bool)
        inside = np.all((rows >= model.lower_limits - LIMIT_TOLERANCE) & (rows <= model.upper_limits + LIMIT_TOLERANCE),
                        axis=1)
        starts = np.concatenate([[0], np.cumsum(count)[:-1]])
        slot = np.arange(len(rows)) - starts[owner]
        q[owner, slot] = rows
        within[owner, slot] = inside
        singular[owner, slot] = sing
        pe[owner, slot] = p
        re[owner, slot] = r
    return AllSolutions(q, count, within, singular, pe, re, complete, s.fam, method)
