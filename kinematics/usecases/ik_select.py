"""One IK request resolved (:class:`IKProblem`) and the strategies that choose its one answer.

An :class:`IKProblem` is what every IK use case works on once the query and the options are read:
the model, the link, the targets, the base poses, the seeds, the :class:`IKOptions` and the
self-collision filter. It gives the two ways to solve -- :meth:`IKProblem.numerical` (damped least
squares, :func:`~kinematics.algorithms.ik.inverse_kinematics`) and :meth:`IKProblem.solution_set`
(every solution, :func:`~kinematics.algorithms.ik_all.all_solutions`, the colliding ones left out)
-- and :meth:`IKProblem.pinocchio_errors`, the verification of any answer, written once.

A :class:`Selection` turns a problem into **one** answer per target (an
:class:`~kinematics.algorithms.ik.IKSolution` and, with collision avoidance, which answers are
free). Three are defined here:

- :class:`Numerical`: the numerical solver's answer;
- :class:`RetryUntilFree`: the numerical answer, then, where it collides, the nearest free
  solution of the full set (a chain with a closed form) or more rounds from fresh seeds;
- :class:`NearestOfSet`: the solution of the full set nearest the seed (the numerical answer,
  without success, where the set is empty).

:func:`selection` chooses among them from the options (``method="analytic"`` or ``locked`` joints:
the set; avoidance: retry; else numerical); a caller may pass another. A new strategy is one class
with :meth:`Selection.work` and :meth:`Selection.select`:
:class:`kinematics.usecases.ik_redundant.BestOverSelfMotion`, the best solution over a redundant
arm's whole self-motion, is one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Protocol

import numpy as np

from ..algorithms import ik_all as _ik_all
from ..algorithms.ik import IKSolution, inverse_kinematics, middle_of_limits, pose_errors
from ..algorithms.ik_collision import free_solutions
from ..errors import KinematicsError
from ..model.robot import RobotModel
from ..spatial.transforms import inverse_transform
from .ik_options import IKOptions
from .query import Query

#: with avoid_collisions, rounds of fresh seeds (each with its restarts) for a target whose answer collides
COLLISION_ROUNDS = 8

Filter = Callable[[np.ndarray], np.ndarray]


class Selection(Protocol):
    """How one answer per target is chosen."""

    #: the strategy looks at the full solution set (a floating base is refused, a default seed is used)
    full_set: bool

    def work(self, model: RobotModel, link: str, options: IKOptions, family=None) -> tuple[int, int]:
        """``(attempts - 1, steps per attempt)`` at most per target, for the budget's ``max_ik_work``
        (``family``: the chain's, which :meth:`IKProblem.of` has detected already for a full-set strategy)."""

    def select(self, problem: IKProblem) -> tuple[IKSolution, np.ndarray | None]:
        """One answer per target, and with collision avoidance ``collision_free`` (N,) (else None)."""


def chain_and_family(model: RobotModel, link: str, locked: dict | None, T_tool=None):
    """The chain to ``link`` with ``locked`` joints folded in and its family
    (:func:`~kinematics.algorithms.ik_all.chain_family`, kept per model: a request's checks and its
    solving detect the family once). A chain with no joint left to move (all locked, or none on the
    way) is a :class:`KinematicsError`: there is nothing to solve (every IK operation, the family
    included, refuses it alike)."""
    chain, family = _ik_all.chain_family(model, link, locked, T_tool)
    if not chain.joints:
        why = "every joint of the chain to {} is locked" if chain.locked else "the chain to {} has no joint"
        raise KinematicsError(why.format(link) + ": nothing left to solve; its pose is the forward kinematics "
                              "of the configuration (fk)")
    return chain, family


#: the most solutions a chain without a known count can have (the general 6R: 16)
MOST_SOLUTIONS = 16


def most_solutions(model: RobotModel, chain, family, limits: str = "respect") -> int:
    """The most solutions one target of ``chain`` (of ``family``) can list: the family's count (or
    :data:`MOST_SOLUTIONS`), times, with ``limits="respect"``, the ``2πk`` copies each revolute joint's
    range holds (a ±2π joint: 2). What a request's answer could hold, known before the work."""
    most = family.max_solutions or MOST_SOLUTIONS
    if limits == "respect":
        cols = chain.columns[chain.revolute]
        span = model.upper_limits[cols] - model.lower_limits[cols]
        span = span[np.isfinite(span)]
        most *= int(np.prod(np.maximum(1.0, np.ceil(span / (2 * np.pi) - 1e-9))))
    return int(most)


def check_solutions(query: Query, n: int, chain, family, limits: str = "respect") -> None:
    """Within the budget's ``max_ik_solutions``: ``n`` targets of ``chain`` listing every solution."""
    most = most_solutions(query.robot, chain, family, limits)
    query.budget.check("max_ik_solutions", n * most, field="target",
                       what=f"IK solutions ({n} targets x up to {most} each: the chain's {family.name} family"
                            + (", with the 2 pi copies within the joint limits)" if limits == "respect" else ")"))


def set_work(model: RobotModel, link: str, options: IKOptions, family=None) -> tuple[int, int]:
    """The work of a full solution set: the closed form's candidates x Newton steps, or the search's
    seeds x its steps (``family``: the chain's, detected here when not given)."""
    wanted = options.solutions
    if family is None:
        family = chain_and_family(model, link, wanted.locked_map)[1]
    if family.closed_form and wanted.method != "numeric":
        return 15, _ik_all.NEAR_STEPS
    return _ik_all.SEARCH_SEEDS - 1, _ik_all.SEARCH_STEPS


@dataclass(frozen=True, eq=False)
class IKProblem:
    """An IK request resolved: ``model`` (the query's robot), ``link``, targets ``T`` (N, 4, 4)
    ``T_world_link`` (``is_batch``: the request gave a list), base poses ``B`` (N, 4, 4) or None,
    the tool ``T_tool`` (4, 4) or None, ``seeds`` (1 or N, dof) or None, the ``options`` and the
    self-collision filter ``free`` (None without avoidance)."""

    query: Query
    model: RobotModel
    link: str
    T: np.ndarray
    is_batch: bool
    B: np.ndarray | None
    T_tool: np.ndarray | None
    seeds: np.ndarray | None
    options: IKOptions
    free: Filter | None

    @classmethod
    def of(cls, query: Query | RobotModel, target: Any, seed: Any, options: IKOptions, query_options: dict[str, Any],
           strategy: Selection) -> IKProblem:
        """The problem of a request: the query (with ``query_options``) read, its targets, link, seeds
        and base poses, the work within the budget (``strategy``'s), the collision filter built."""
        query = Query.of(query, **query_options)
        if strategy.full_set and query.floating_base:
            raise KinematicsError("floating_base: every IK solution needs a fixed base (give the base pose as base)")
        model, budget = query.robot, query.budget
        T, is_batch = query.targets(target)
        N = T.shape[0]
        link = query.frame_link()
        free = options.collisions.filter(model, query.collision_pairs) if options.collisions is not None else None
        if strategy.full_set:  # the largest answer the set could be, before the work (the family detected once)
            chain, family = chain_and_family(model, link, options.solutions.locked_map)
            check_solutions(query, N, chain, family, options.solutions.solution_limits)
            budget.check_ik_work(N, *strategy.work(model, link, options, family=family))
        else:
            budget.check_ik_work(N, *strategy.work(model, link, options))
        seeds = query.seeds(seed, N)
        B = query.base_poses(N)
        return cls(query, model, link, T, is_batch, None if B is None else np.ascontiguousarray(B), query.T_tool,
                   seeds, options, free)

    @property
    def start(self) -> np.ndarray:
        """The seeds (1 or N, dof), the middle of the limits without any."""
        return middle_of_limits(self.model)[None] if self.seeds is None else self.seeds

    def numerical(self, rows: np.ndarray | None = None, seeds: np.ndarray | None = None,
                  random_seed: int | None = None) -> IKSolution:
        """:func:`~kinematics.algorithms.ik.inverse_kinematics` of the targets ``rows`` (indices; None:
        all) from ``seeds`` (default the problem's) with the options' settings (``random_seed``
        replaced for a further round)."""
        T, B, S = self.T, self.B, self.seeds if seeds is None else seeds
        if rows is not None:
            B = None if B is None else np.broadcast_to(B, (len(T), 4, 4))[rows]
            T = T[rows]
        return inverse_kinematics(self.model, self.link, T, S, base=B, tool=self.T_tool,
                                  **self.options.settings.solver(random_seed))

    def solution_set(self, seeds: np.ndarray | None = None) -> tuple[_ik_all.AllSolutions, np.ndarray | None]:
        """``(every solution, colliding (N,) or None)``: :func:`~kinematics.algorithms.ik_all.all_solutions`
        of the options' set, nearest ``seeds`` first (default the problem's), the colliding solutions
        left out with avoidance (joints off the chain, which collide too, at the seed's values; without
        a seed at the middle of their limits, numerical IK's default seed)."""
        seeds = self.seeds if seeds is None else seeds
        wanted, model = self.options.solutions, self.model
        sol = _ik_all.all_solutions(model, self.link, self.T, base=self.B, tool=self.T_tool, locked=wanted.locked_map,
                                    limits=wanted.solution_limits, method=wanted.method, seed=seeds,
                                    **self.options.settings.tolerances())
        if self.free is None:
            return sol, None
        if seeds is None:
            sol = _off_chain_at_middle(model, self.link, wanted.locked_map, self.T_tool, sol)
        return free_solutions(sol, self.free)

    def pinocchio_errors(self, Q: np.ndarray, rows: np.ndarray) -> tuple[str, np.ndarray, np.ndarray]:
        """Pinocchio's FK of the configurations ``Q`` (R, dof) against the targets ``rows`` (R,): the
        reference's name, position (m) and rotation (rad) errors (R,) -- the verification of every IK answer."""
        from ..verify.pinocchio import REFERENCE_NAME, reference_for

        frames = reference_for(self.model).frames([self.link], self.T_tool)
        theirs = np.array([frames.poses(q)[self.link] for q in Q]).reshape(len(Q), 4, 4)
        T_root = self.T if self.B is None else np.matmul(inverse_transform(self.B), self.T)
        return (REFERENCE_NAME, *pose_errors(theirs, T_root[rows]))


def _off_chain_at_middle(model: RobotModel, link: str, locked, T_tool, sol):
    """``sol`` with the joints off the chain to ``link`` (neither moved nor locked) at the middle of
    their limits, the default seed of numerical IK; ``within_limits`` measured again."""
    import dataclasses

    from ..tolerances import LIMIT_TOLERANCE

    chain = _ik_all.chain_family(model, link, locked, T_tool)[0]
    held = set(chain.columns.tolist()) | {model.q_index[name] for name in chain.locked}
    off = np.array([c for c in range(model.dof) if c not in held], dtype=np.intp)
    if off.size == 0:
        return sol
    listed = np.arange(sol.q.shape[1])[None, :] < sol.count[:, None]
    q = sol.q.copy()
    q[..., off] = np.where(listed[..., None], middle_of_limits(model)[off], np.nan)
    inside = np.all((q >= model.lower_limits - LIMIT_TOLERANCE) & (q <= model.upper_limits + LIMIT_TOLERANCE), axis=2)
    return dataclasses.replace(sol, q=q, within_limits=inside & listed)


class Numerical:
    """The numerical solver's answer (damped least squares from the seed, then random restarts)."""

    full_set = False

    def work(self, model: RobotModel, link: str, options: IKOptions) -> tuple[int, int]:
        return options.settings.restarts, options.settings.max_iterations

    def select(self, problem: IKProblem) -> tuple[IKSolution, np.ndarray | None]:
        return problem.numerical(), None


class RetryUntilFree(Numerical):
    """Numerical IK that goes on where an answer collides: ``(the solution, collision_free (N,))``.

    Targets whose answer succeeded but is in self-collision take, where the chain has a closed form,
    the free solution of the full set (limits respected) nearest the seed -- the set is complete,
    so a target without one has no free solution inside the limits; on other chains they get up
    to :data:`COLLISION_ROUNDS` more rounds of the numerical solver, each from a fresh seed drawn
    within the limits (seeded by ``random_seed``) with its own restarts. ``success`` is true only
    for an answer that meets the tolerances, the limits and is free."""

    def work(self, model: RobotModel, link: str, options: IKOptions) -> tuple[int, int]:
        # a colliding answer may take COLLISION_ROUNDS more rounds of its restarts
        return (COLLISION_ROUNDS + 1) * (options.settings.restarts + 1) - 1, options.settings.max_iterations

    def select(self, problem: IKProblem) -> tuple[IKSolution, np.ndarray | None]:
        solution = problem.numerical()
        model, link, T, free_of, settings = problem.model, problem.link, problem.T, problem.free, problem.options.settings
        N = len(T)
        q, position, rotation = solution.q.copy(), solution.position_error.copy(), solution.rotation_error.copy()
        success, iterations = solution.success.copy(), solution.iterations.copy()
        free = np.zeros(N, bool)
        if success.any():
            free[success] = free_of(q[success])
        start = np.broadcast_to(problem.start, (N, model.dof))
        B_all = None if problem.B is None else np.broadcast_to(problem.B, (N, 4, 4))
        todo = np.flatnonzero(success & ~free)  # an unreachable target stays what its restarts found
        full_set = False
        if todo.size and not model.multi_dof:
            try:
                if _ik_all.chain_family(model, link, None, problem.T_tool)[1].closed_form:
                    sol = _ik_all.all_solutions(model, link, T[todo], base=None if B_all is None else B_all[todo],
                                                tool=problem.T_tool, seed=start[todo], **settings.tolerances())
                    sol, _ = free_solutions(sol, free_of)
                    has = np.flatnonzero(sol.count > 0)
                    if has.size:
                        hit = todo[has]
                        q[hit] = sol.q[has, 0]
                        position[hit], rotation[hit] = sol.position_error[has, 0], sol.rotation_error[has, 0]
                        success[hit], free[hit] = sol.within_limits[has, 0], True
                    full_set = True
            except KinematicsError:  # no full set for this chain (position mode on six joints, a redundant chain)
                pass
        if not full_set:
            lo = np.where(np.isfinite(model.lower_limits), model.lower_limits, -np.pi)
            hi = np.where(np.isfinite(model.upper_limits), model.upper_limits, np.pi)
            rng = np.random.default_rng([int(settings.random_seed) & 0xFFFFFFFF, 0xC0111DE])
            for r in range(COLLISION_ROUNDS):
                if todo.size == 0:
                    break
                S = rng.uniform(lo, hi, (len(todo), model.dof))
                again = problem.numerical(todo, S, settings.random_seed + 1 + r)
                iterations[todo] += again.iterations
                got = np.flatnonzero(again.success)
                ok = np.zeros(len(todo), bool)
                if got.size:
                    ok[got] = free_of(again.q[got])
                hit = todo[ok]
                q[hit], position[hit], rotation[hit] = again.q[ok], again.position_error[ok], again.rotation_error[ok]
                success[hit], free[hit] = True, True
                todo = todo[~ok]
        # what is answered: a colliding answer (the best found) is no success
        still = np.flatnonzero(~free)
        if still.size:
            free[still] = free_of(q[still])
        return IKSolution(q, success & free, position, rotation, iterations), free


class NearestOfSet:
    """The first solution of each target's full set (nearest the seed, by default the middle of the
    limits; with avoidance, of the free ones); the numerical answer, without success, where the set
    is empty (the closed form, or the locked chain, has no solution: none is claimed)."""

    full_set = True

    def work(self, model: RobotModel, link: str, options: IKOptions, family=None) -> tuple[int, int]:
        return set_work(model, link, options, family)

    def select(self, problem: IKProblem) -> tuple[IKSolution, np.ndarray | None]:
        seeds = problem.start
        sol, _ = problem.solution_set(seeds)
        return first_of_each(problem, sol, seeds)


def first_of_each(problem: IKProblem, sol, seeds: np.ndarray) -> tuple[IKSolution, np.ndarray | None]:
    """The first solution of each target's set ``sol`` (padded ``q``, ``count``, ``position_error``,
    ``rotation_error``) as one answer per target; where the set is empty, the numerical answer from
    ``seeds`` (1 or N, dof), without success (none is claimed). With collision avoidance, success
    only for a free answer, and which are free."""
    N = len(problem.T)
    K = sol.q.shape[1]
    has = sol.count > 0
    q = np.where(has[:, None], np.nan_to_num(sol.q[:, 0]) if K else 0.0, 0.0)
    position = np.where(has, sol.position_error[:, 0] if K else 0.0, np.nan)
    rotation = np.where(has, sol.rotation_error[:, 0] if K else 0.0, np.nan)
    success = has.copy()
    iterations = np.zeros(N, dtype=np.int64)
    missing = np.flatnonzero(~has)
    if missing.size:
        fallback = problem.numerical(missing, seeds[missing % len(seeds)])
        q[missing] = fallback.q
        position[missing], rotation[missing] = fallback.position_error, fallback.rotation_error
        iterations[missing] = fallback.iterations
    free = None
    if problem.free is not None:  # the first of the free solutions; where none is free, no success
        free = problem.free(q)
        success &= free
    return IKSolution(q, success, position, rotation, iterations), free


def selection(options: IKOptions) -> Selection:
    """The strategy of the options: :class:`NearestOfSet` with ``method="analytic"`` or ``locked``
    joints, else :class:`RetryUntilFree` with collision avoidance, else :class:`Numerical`."""
    wanted = options.solutions
    if wanted.method == "analytic" or wanted.locked:
        return NearestOfSet()
    return RetryUntilFree() if options.collisions is not None else Numerical()
