"""Inverse kinematics: joint values putting the query's link (or its point / tool frame) at targets."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..algorithms import ik as _ik
from ..algorithms import ik_all as _ik_all
from ..algorithms.collision_matrix import DEFAULT_SAMPLES as COLLISION_SAMPLES
from ..algorithms.ik import IKSolution, inverse_kinematics, middle_of_limits, pose_errors
from ..algorithms.ik_collision import free_solutions
from ..algorithms.ik_families import detect, reduce_chain
from ..errors import KinematicsError
from ..model.robot import RobotModel
from ..spatial.transforms import inverse_transform
from .collision import collision_filter
from .ik_all import SOLUTIONS, ik_all
from .ik_redundant import ik_redundant
from .query import Query

#: with avoid_collisions, rounds of fresh seeds (each with its restarts) for a target whose answer collides
COLLISION_ROUNDS = 8


@dataclass(frozen=True, eq=False)
class IKAnswer:
    """IK answers for N targets (``is_batch``: the request gave a list of targets)."""

    model: RobotModel
    link: str
    mode: str
    is_batch: bool
    targets: np.ndarray  # (N, 4, 4) T_world_link
    solution: IKSolution
    verification: dict[str, Any] | None = None  # Pinocchio's FK of every answer against its target
    collision_free: np.ndarray | None = None  # (N,) with avoid_collisions: the answer is free of self-collision


def ik(query: Query | RobotModel, target: Any, *, seed: Any = None, mode: str = "pose",
       position_tolerance: float = _ik.DEFAULT_POSITION_TOLERANCE,
       rotation_tolerance: float = _ik.DEFAULT_ROTATION_TOLERANCE,
       max_iterations: int = _ik.DEFAULT_MAX_ITERATIONS, restarts: int = _ik.DEFAULT_RESTARTS,
       random_seed: int = 0, solutions: str = "one", method: str = "auto", locked: dict | None = None,
       limits: str = "respect", avoid_collisions: bool = False, collision_samples: int = COLLISION_SAMPLES,
       cache_dir: Any = None, redundancy: Any = None, **options: Any):
    """Joint values putting the query's ``link`` (None: the first leaf link) at ``target``: one pose
    or a list (any form :func:`~kinematics.io.poses.pose_list` reads, or an (N, 4, 4) array),
    ``T_world_link``. With the query's ``point`` or ``tool`` the targets are poses of that frame,
    ``T_world_link @ T_link_tool`` (a TCP without editing the URDF).

    ``seed``: one q (vector or name map) for every target, or one per target; default the middle
    of the limits (read with the query's ``normalize``). The query's ``base`` as for
    :func:`~kinematics.usecases.fk.fk`. ``success`` holds only where the answer's FK is within the
    tolerances and the answer inside the limits (:mod:`kinematics.algorithms.ik`). ``verify``:
    Pinocchio's FK of every answer, against its target. With ``floating_base`` the answer has
    ``7 + n`` values; models with floating or planar joints are solved on the configuration
    manifold (:func:`kinematics.algorithms.ik.tree_inverse_kinematics`). Work is bounded by the
    budget's ``max_batch`` (targets), ``max_verify`` and ``max_ik_work``.

    ``solutions="all"``: **every** solution, an :class:`~kinematics.usecases.ik_all.IKAllAnswer`
    (``method`` ``auto`` / ``analytic`` / ``numeric``, ``locked`` ``{joint: value}``, ``limits``
    ``respect`` / ``ignore``: :func:`kinematics.usecases.ik_all.ik_all`). ``solutions="one"`` with
    ``method="analytic"`` or ``locked`` joints: the solution nearest the seed among all of them.

    ``avoid_collisions``: only answers free of self-collision (the enabled pairs of the model's
    allowed-collision matrix from ``collision_samples`` configurations, kept in ``cache_dir``; a
    model without collision geometry is a :class:`~kinematics.errors.CollisionError`). With
    ``solutions="all"`` the colliding solutions are left out (counted in ``colliding``); with
    ``"one"`` the search goes on where the answer collides -- for a chain with a closed form, the
    solution nearest the seed among the free ones of the full set; otherwise up to
    :data:`COLLISION_ROUNDS` rounds of fresh seeds within the limits, each with its restarts --
    and ``success`` holds only for a free answer (``collision_free`` (N,) says which are).
    """
    if solutions not in SOLUTIONS:
        raise KinematicsError(f"solutions: {solutions!r} is not one of {', '.join(SOLUTIONS)}")
    if redundancy is not None:  # a 7-joint chain's self-motion (kinematics.usecases.ik_redundant)
        if solutions != "all" or avoid_collisions:
            raise KinematicsError("redundancy: give it with solutions 'all' (avoid_collisions is not supported)")
        return ik_redundant(query, target, redundancy=redundancy, seed=seed, locked=locked, limits=limits, mode=mode,
                            position_tolerance=position_tolerance, rotation_tolerance=rotation_tolerance, **options)
    if method not in ("auto", "analytic", "numeric"):
        raise KinematicsError(f"method: {method!r} is not one of auto, analytic, numeric")
    if solutions == "all" or method == "analytic" or locked:
        answer = ik_all(query, target, seed=seed, mode=mode, position_tolerance=position_tolerance,
                        rotation_tolerance=rotation_tolerance, method=method, locked=locked, limits=limits,
                        one=solutions == "one", max_iterations=max_iterations, restarts=restarts,
                        random_seed=random_seed, avoid_collisions=avoid_collisions,
                        collision_samples=collision_samples, cache_dir=cache_dir, **options)
        if solutions == "all":
            return answer
        link, T, is_batch, solution = answer
        model = Query.of(query, **options).robot
        free = None
        if avoid_collisions:  # the nearest of the free solutions; where none is free, no success
            free = collision_filter(model, "avoid_collisions", samples=collision_samples, cache_dir=cache_dir)(
                solution.q)
            solution = IKSolution(solution.q, solution.success & free, solution.position_error,
                                  solution.rotation_error, solution.iterations)
        return IKAnswer(model, link, mode, is_batch, T, solution, collision_free=free)
    query = Query.of(query, **options)
    model, budget = query.robot, query.budget
    free_of = (collision_filter(model, "avoid_collisions", samples=collision_samples, cache_dir=cache_dir)
               if avoid_collisions else None)
    T, is_batch = query.targets(target)
    N = T.shape[0]
    # with avoid_collisions a colliding answer may take COLLISION_ROUNDS more rounds of its restarts
    rounds = COLLISION_ROUNDS + 1 if avoid_collisions else 1
    budget.check_ik_work(N, rounds * (restarts + 1) - 1, max_iterations)
    link = query.frame_link()
    seeds = query.seeds(seed, N)
    B = query.base_poses(N)
    B = None if B is None else np.ascontiguousarray(B)
    T_tool = query.T_tool
    solution = inverse_kinematics(model, link, T, seeds, base=B, mode=mode, position_tolerance=position_tolerance,
                                  rotation_tolerance=rotation_tolerance, max_iterations=max_iterations,
                                  restarts=restarts, random_seed=random_seed, tool=T_tool)
    free = None
    if free_of is not None:
        solution, free = _search_free(model, link, T, seeds, B, T_tool, solution, free_of, mode=mode,
                                      position_tolerance=position_tolerance, rotation_tolerance=rotation_tolerance,
                                      max_iterations=max_iterations, restarts=restarts, random_seed=random_seed)
    verification = None
    if query.verify:
        from ..verify.pinocchio import REFERENCE_NAME, reference_for

        frames = reference_for(model).frames([link], T_tool)
        theirs = np.array([frames.poses(q)[link] for q in solution.q]).reshape(N, 4, 4)
        T_root = T if B is None else np.matmul(inverse_transform(B), T)
        position, rotation = pose_errors(theirs, T_root)
        verification = {"reference": REFERENCE_NAME, "position_error": position, "rotation_error": rotation}
    return IKAnswer(model, link, mode, is_batch, T, solution, verification, free)


def _search_free(model: RobotModel, link: str, T: np.ndarray, seeds, B, T_tool, solution: IKSolution, free_of, *,
                 mode: str, position_tolerance: float, rotation_tolerance: float, max_iterations: int, restarts: int,
                 random_seed: int) -> tuple[IKSolution, np.ndarray]:
    """Numerical IK that goes on where an answer collides: ``(the solution, collision_free (N,))``.

    Targets whose answer succeeded but is in self-collision take, where the chain has a closed form,
    the free solution of the full set (limits respected) nearest the seed -- the set is complete,
    so a target without one has no free solution inside the limits; on other chains they get up
    to :data:`COLLISION_ROUNDS` more rounds of the numerical solver, each from a fresh seed drawn
    within the limits (seeded by ``random_seed``) with its own restarts. ``success`` is true only
    for an answer that meets the tolerances, the limits and is free."""
    N = len(T)
    q, position, rotation = solution.q.copy(), solution.position_error.copy(), solution.rotation_error.copy()
    success, iterations = solution.success.copy(), solution.iterations.copy()
    free = np.zeros(N, bool)
    if success.any():
        free[success] = free_of(q[success])
    start = np.broadcast_to(middle_of_limits(model)[None] if seeds is None else seeds, (N, model.dof))
    B_all = None if B is None else np.broadcast_to(B, (N, 4, 4))
    todo = np.flatnonzero(success & ~free)  # an unreachable target stays what its restarts found
    full_set = False
    if todo.size and not model.multi_dof:
        try:
            if detect(reduce_chain(model, link, None, T_tool)).closed_form:
                sol = _ik_all.all_solutions(model, link, T[todo], base=None if B_all is None else B_all[todo],
                                            tool=T_tool, seed=start[todo], mode=mode,
                                            position_tolerance=position_tolerance,
                                            rotation_tolerance=rotation_tolerance)
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
        rng = np.random.default_rng([int(random_seed) & 0xFFFFFFFF, 0xC0111DE])
        for r in range(COLLISION_ROUNDS):
            if todo.size == 0:
                break
            S = rng.uniform(lo, hi, (len(todo), model.dof))
            again = inverse_kinematics(model, link, T[todo], S, base=None if B_all is None else B_all[todo],
                                       mode=mode, position_tolerance=position_tolerance,
                                       rotation_tolerance=rotation_tolerance, max_iterations=max_iterations,
                                       restarts=restarts, random_seed=random_seed + 1 + r, tool=T_tool)
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
