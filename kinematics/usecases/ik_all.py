"""Every IK solution, the family of a chain, and Cartesian paths (:mod:`kinematics.algorithms.ik_all`,
:mod:`kinematics.algorithms.ik_families`, :mod:`kinematics.algorithms.ik_path`).

>>> from kinematics.io import default_catalogue
>>> from kinematics.usecases.fk import fk
>>> ur5 = default_catalogue().get("ur5")
>>> T = fk(ur5, [0.3, -1.0, 1.2, -0.5, 0.8, 0.2], links=["tool0"]).poses[0, 0]
>>> a = ik_all(Query(ur5, link="tool0"), T, limits="ignore")
>>> a.family, a.method, int(a.count[0]), bool(a.position_error[0, :8].max() < 1e-9)
('three_parallel', 'analytic', 8, True)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable

import numpy as np

from ..algorithms import ik as _ik
from ..algorithms import ik_all as _ik_all
from ..algorithms import ik_path as _ik_path
from ..algorithms.collision_matrix import DEFAULT_SAMPLES as COLLISION_SAMPLES
from ..algorithms.ik import IKSolution, inverse_kinematics, pose_errors
from ..algorithms.ik_collision import free_solutions
from ..algorithms.ik_families import detect, reduce_chain
from ..algorithms.ik_redundant import family_fields
from ..errors import JointValueError, KinematicsError
from ..io.poses import pose_list
from ..model.robot import RobotModel
from ..spatial.transforms import inverse_transform
from .collision import collision_filter
from .query import Query

SOLUTIONS = ("one", "all")


@dataclass(frozen=True, eq=False)
class IKAllAnswer(_ik_all.SolutionArrays):
    """Every IK solution of N targets (``is_batch``: the request gave a list).

    ``q`` (N, K, dof) padded with NaN, ``count`` (N,), ``within_limits``, ``singular`` (N, K) bool,
    ``position_error``, ``rotation_error`` (N, K), ``complete`` (N,): see
    :class:`~kinematics.algorithms.ik_all.SolutionArrays`; ``family`` (its name), ``method``
    (``"analytic"`` or ``"search"``); ``verification``: Pinocchio's FK of every listed solution
    (``max_position_error``, ``max_rotation_error`` against its target); ``colliding`` (N,) with
    ``avoid_collisions``: how many solutions of each target were left out as in self-collision
    (None without it).
    """

    model: RobotModel
    link: str
    mode: str
    is_batch: bool
    targets: np.ndarray
    family: str
    method: str
    locked: dict
    verification: dict[str, Any] | None = None
    colliding: np.ndarray | None = None

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self.model.joint_names


def parse_locked(items: Iterable[str] | None) -> dict[str, float]:
    """``JOINT:VALUE`` strings (the command line's ``--locked``, the service's ``locked`` query
    parameters) as the ``locked`` map ``{joint: value}``; a malformed one is a :class:`ValueError`
    naming it.

    >>> parse_locked(["shoulder_pan_joint:0.5", "wrist_3_joint:-1"])
    {'shoulder_pan_joint': 0.5, 'wrist_3_joint': -1.0}
    """
    out: dict[str, float] = {}
    for item in items or ():
        name, sep, value = item.rpartition(":")
        try:
            if not sep or not name:
                raise ValueError
            out[name] = float(value)
        except ValueError:
            raise ValueError(f"{item!r} is not JOINT:VALUE") from None
    return out


def ik_all(query: Query | RobotModel, target: Any, *, seed: Any = None, mode: str = "pose",
           position_tolerance: float = _ik.DEFAULT_POSITION_TOLERANCE,
           rotation_tolerance: float = _ik.DEFAULT_ROTATION_TOLERANCE, method: str = "auto",
           locked: dict | None = None, limits: str = "respect", one: bool = False,
           max_iterations: int = _ik.DEFAULT_MAX_ITERATIONS, restarts: int = _ik.DEFAULT_RESTARTS,
           random_seed: int = 0, avoid_collisions: bool = False, collision_samples: int = COLLISION_SAMPLES,
           cache_dir: Any = None, **options: Any):
    """Every solution putting the query's link (or its point / tool frame) at ``target`` (one pose or
    a list, ``T_world_link``): an :class:`IKAllAnswer`. ``method``: ``auto`` (the closed form of the
    chain's family where it has one, else the multistart search), ``analytic`` (the closed form or a
    :class:`~kinematics.errors.KinematicsError`), ``numeric`` (the search); ``locked``
    ``{joint: value}``; ``limits``: ``respect`` or ``ignore``; ``seed``: solutions nearest it first.
    ``one``: ``(link, targets, is_batch, IKSolution)`` of the solution nearest the seed (default the
    middle of the limits), today's numerical answer (``success`` false) where there is none
    (:func:`kinematics.usecases.ik.ik` answers it).

    ``avoid_collisions``: only the solutions free of self-collision are listed (the enabled pairs of
    the model's allowed-collision matrix from ``collision_samples`` configurations, kept in
    ``cache_dir``; :func:`kinematics.usecases.collision.collision_filter`, which refuses a model
    without collision geometry); the answer's ``colliding`` counts those left out. Joints off the
    chain (a gripper's fingers) take the seed's values, without a seed the middle of their limits
    (numerical IK's default seed; without ``avoid_collisions``: 0), since they collide too."""
    query = Query.of(query, **options)
    if query.floating_base:
        raise KinematicsError("floating_base: every IK solution needs a fixed base (give the base pose as base)")
    model, budget = query.robot, query.budget
    T, is_batch = query.targets(target)
    N = T.shape[0]
    link = query.frame_link()
    free = (collision_filter(model, "avoid_collisions", samples=collision_samples, cache_dir=cache_dir)
            if avoid_collisions else None)
    # the work: candidates x Newton steps per target (the search: its seeds x its steps)
    if detect(reduce_chain(model, link, locked)).closed_form and method != "numeric":
        budget.check_ik_work(N, 15, _ik_all.NEAR_STEPS)
    else:
        budget.check_ik_work(N, _ik_all.SEARCH_SEEDS - 1, _ik_all.SEARCH_STEPS)
    seeds = query.seeds(seed, N)
    if seeds is None and one:
        seeds = _ik.middle_of_limits(model)[None]
    B = query.base_poses(N)
    T_tool = query.T_tool
    sol = _ik_all.all_solutions(model, link, T, base=B, tool=T_tool, locked=locked, limits=limits, method=method,
                                seed=seeds, mode=mode, position_tolerance=position_tolerance,
                                rotation_tolerance=rotation_tolerance)
    colliding = None
    if free is not None:
        if seeds is None:  # joints off the chain (a gripper) at the middle of their limits, not at 0
            sol = _off_chain_at_middle(model, link, locked, T_tool, sol)
        sol, colliding = free_solutions(sol, free)
    if one:  # (link, targets, is_batch, the IKSolution) for kinematics.usecases.ik.ik to answer
        return link, T, is_batch, _nearest(model, link, T, B, T_tool, sol, seeds, mode, position_tolerance,
                                           rotation_tolerance, max_iterations, restarts, random_seed)
    verification = None
    if query.verify:
        from ..verify.pinocchio import REFERENCE_NAME, reference_for

        frames = reference_for(model).frames([link], T_tool)
        T_root = T if B is None else np.matmul(inverse_transform(B), T)
        worst_p = worst_r = 0.0
        for n in range(N):
            for k in range(int(sol.count[n])):
                p, r = pose_errors(frames.poses(sol.q[n, k])[link][None], T_root[n:n + 1])
                worst_p, worst_r = max(worst_p, float(p[0])), max(worst_r, float(r[0]))
        verification = {"reference": REFERENCE_NAME, "max_position_error": worst_p, "max_rotation_error": worst_r}
    return IKAllAnswer(sol.q, sol.count, sol.within_limits, sol.singular, sol.position_error, sol.rotation_error,
                       sol.complete, model=model, link=link, mode=mode, is_batch=is_batch, targets=T,
                       family=sol.family.name, method=sol.method, locked=dict(sol.family.chain.locked),
                       verification=verification, colliding=colliding)


def _off_chain_at_middle(model: RobotModel, link: str, locked, T_tool, sol):
    """``sol`` with the joints off the chain to ``link`` (neither moved nor locked) at the middle of
    their limits, the default seed of numerical IK; ``within_limits`` measured again."""
    import dataclasses

    from ..tolerances import LIMIT_TOLERANCE

    chain = reduce_chain(model, link, locked, T_tool)
    held = set(chain.columns.tolist()) | {model.q_index[name] for name in chain.locked}
    off = np.array([c for c in range(model.dof) if c not in held], dtype=np.intp)
    if off.size == 0:
        return sol
    listed = np.arange(sol.q.shape[1])[None, :] < sol.count[:, None]
    q = sol.q.copy()
    q[..., off] = np.where(listed[..., None], _ik.middle_of_limits(model)[off], np.nan)
    inside = np.all((q >= model.lower_limits - LIMIT_TOLERANCE) & (q <= model.upper_limits + LIMIT_TOLERANCE), axis=2)
    return dataclasses.replace(sol, q=q, within_limits=inside & listed)


def _nearest(model, link, T, B, T_tool, sol, seeds, mode, position_tolerance, rotation_tolerance, max_iterations,
             restarts, random_seed) -> IKSolution:
    """The first (nearest the seed) solution of each target; today's numerical answer where there is none."""
    N = len(T)
    K = sol.q.shape[1]
    has = sol.count > 0
    q = np.where(has[:, None], np.nan_to_num(sol.q[:, 0]) if K else 0.0, 0.0)
    position = np.where(has, sol.position_error[:, 0] if K else 0.0, np.nan)
    rotation = np.where(has, sol.rotation_error[:, 0] if K else 0.0, np.nan)
    success = has.copy()
    iterations = np.zeros(N, dtype=np.int64)
    missing = np.flatnonzero(~has)
    if missing.size:
        fallback = inverse_kinematics(model, link, T[missing], seeds[missing % len(seeds)],
                                      base=None if B is None else np.broadcast_to(B, (N, 4, 4))[missing], mode=mode,
                                      position_tolerance=position_tolerance, rotation_tolerance=rotation_tolerance,
                                      max_iterations=max_iterations, restarts=restarts, random_seed=random_seed,
                                      tool=T_tool)
        q[missing] = fallback.q
        position[missing], rotation[missing] = fallback.position_error, fallback.rotation_error
        iterations[missing] = fallback.iterations
        success[missing] = False  # the closed form (or the locked chain) has no solution: none is claimed
    return IKSolution(q, success, position, rotation, iterations)


def ik_family(query: Query | RobotModel, *, locked: dict | None = None, **options: Any) -> dict[str, Any]:
    """The family of the chain to the query's link with ``locked`` joints held: ``{link, joints, locked,
    family, closed_form, max_solutions, subproblems, reversed, near}``."""
    query = Query.of(query, **options)
    link = query.frame_link()
    chain = reduce_chain(query.robot, link, locked, query.T_tool)
    fam = detect(chain)
    return {"link": link, "joints": list(chain.joints), "locked": dict(chain.locked), **fam.as_dict(),
            **family_fields(query.robot, link, locked, query.T_tool)}  # a 7-joint chain: its self-motion


def ik_path(query: Query | RobotModel, waypoints: Any, *, seed: Any = None, step: dict | None = None,
            max_joint_step: float = _ik_path.DEFAULT_MAX_JOINT_STEP,
            position_tolerance: float = _ik.DEFAULT_POSITION_TOLERANCE,
            rotation_tolerance: float = _ik.DEFAULT_ROTATION_TOLERANCE, locked: dict | None = None,
            avoid_collisions: bool = False, collision_samples: int = COLLISION_SAMPLES, cache_dir: Any = None,
            **options: Any) -> _ik_path.PathAnswer:
    """A Cartesian path of the query's link through ``waypoints`` (two or more poses, world frame) from
    ``seed`` (the start configuration): :func:`kinematics.algorithms.ik_path.cartesian_path`.
    ``step``: ``{"position": m, "rotation": rad}``, the largest step between consecutive targets.
    ``avoid_collisions``: the path stops at its first row in self-collision, ``stopped`` ``{"index",
    "reason": "collision"}`` (the matrix of ``collision_samples`` configurations, kept in ``cache_dir``;
    a model without collision geometry is refused)."""
    query = Query.of(query, **options)
    free = (collision_filter(query.robot, "avoid_collisions", samples=collision_samples, cache_dir=cache_dir)
            if avoid_collisions else None)
    W, _ = pose_list(waypoints, "waypoints")
    link = query.frame_link()
    q0 = None
    if seed is not None:
        S = query.seeds(seed, 1)
        if S.shape[0] != 1:
            raise JointValueError("seed: give one start configuration")
        q0 = S[0]
    step = step or {}
    B = query.base_poses(1)
    return _ik_path.cartesian_path(query.robot, link, W, q0, base=None if B is None else B.reshape(-1, 4, 4)[0],
                                   tool=query.T_tool, locked=locked,
                                   step_position=float(step.get("position", _ik_path.DEFAULT_STEP_POSITION)),
                                   step_rotation=float(step.get("rotation", _ik_path.DEFAULT_STEP_ROTATION)),
                                   max_joint_step=max_joint_step, position_tolerance=position_tolerance,
                                   rotation_tolerance=rotation_tolerance, collision_free=free)
