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

from ..algorithms import ik_all as _ik_all
from ..algorithms import ik_path as _ik_path
from ..algorithms import ik_path_redundant as _ik_path_redundant
from ..algorithms.ik_redundant import SelfMotion, family_fields
from ..errors import JointValueError, KinematicsError
from ..io.poses import pose_list
from ..model.robot import RobotModel
from .ik_options import IKOptions
from .ik_select import IKProblem, NearestOfSet, chain_and_family, check_solutions, most_solutions
from .query import Query



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


def ik_all(query: Query | RobotModel, target: Any, *, seed: Any = None, options: IKOptions | None = None,
           **keywords: Any) -> IKAllAnswer:
    """Every solution putting the query's link (or its point / tool frame) at ``target`` (one pose or
    a list, ``T_world_link``): an :class:`IKAllAnswer`. ``options``
    (:class:`~kinematics.usecases.ik_options.IKOptions`, or its fields as keywords, as
    :func:`kinematics.usecases.ik.ik` takes them): ``method`` ``auto`` (the closed form of the chain's
    family where it has one, else the multistart search), ``analytic`` (the closed form or a
    :class:`~kinematics.errors.KinematicsError`), ``numeric`` (the search); ``locked``
    ``{joint: value}``; ``limits``: ``respect`` or ``ignore``; ``seed``: solutions nearest it first.

    ``avoid_collisions``: only the solutions free of self-collision are listed (the enabled pairs of
    the model's allowed-collision matrix from ``collision_samples`` configurations, kept in
    ``cache_dir``; :func:`kinematics.usecases.collision.collision_filter`, which refuses a model
    without collision geometry); the answer's ``colliding`` counts those left out. Joints off the
    chain (a gripper's fingers) take the seed's values, without a seed the middle of their limits
    (numerical IK's default seed; without ``avoid_collisions``: 0), since they collide too."""
    options, rest = IKOptions.split(options, keywords)
    problem = IKProblem.of(query, target, seed, options, rest, NearestOfSet())  # the same problem, the full set
    sol, colliding = problem.solution_set()
    verification = None
    if problem.query.verify:
        listed = np.arange(sol.q.shape[1])[None, :] < sol.count[:, None]
        n_idx, k_idx = np.nonzero(listed)
        reference, p, r = problem.pinocchio_errors(sol.q[n_idx, k_idx], n_idx)
        verification = {"reference": reference, "max_position_error": float(p.max(initial=0.0)),
                        "max_rotation_error": float(r.max(initial=0.0))}
    return IKAllAnswer(sol.q, sol.count, sol.within_limits, sol.singular, sol.position_error, sol.rotation_error,
                       sol.complete, model=problem.model, link=problem.link, mode=options.settings.mode,
                       is_batch=problem.is_batch, targets=problem.T, family=sol.family.name, method=sol.method,
                       locked=dict(sol.family.chain.locked), verification=verification, colliding=colliding)


def ik_family(query: Query | RobotModel, *, locked: dict | None = None, **options: Any) -> dict[str, Any]:
    """The family of the chain to the query's link with ``locked`` joints held: ``{link, joints, locked,
    family, closed_form, max_solutions, subproblems, reversed, near}``."""
    query = Query.of(query, **options)
    link = query.frame_link()
    chain, fam = chain_and_family(query.robot, link, locked, query.T_tool)
    return {"link": link, "joints": list(chain.joints), "locked": dict(chain.locked), **fam.as_dict(),
            **family_fields(query.robot, link, locked, query.T_tool)}  # a 7-joint chain: its self-motion


def ik_path(query: Query | RobotModel, waypoints: Any, *, seed: Any = None, step: dict | None = None,
            max_joint_step: float = _ik_path.DEFAULT_MAX_JOINT_STEP, options: IKOptions | None = None,
            **keywords: Any) -> _ik_path.PathAnswer:
    """A Cartesian path of the query's link through ``waypoints`` (two or more poses, world frame) from
    ``seed`` (the start configuration): :func:`kinematics.algorithms.ik_path.cartesian_path`.
    ``step``: ``{"position": m, "rotation": rad}``, the largest step between consecutive targets.
    ``avoid_collisions``: the path stops at its first row in self-collision, ``stopped`` ``{"index",
    "reason": "collision"}`` (the matrix of ``collision_samples`` configurations, kept in ``cache_dir``;
    a model without collision geometry is refused).

    ``redundancy`` ``{"select": "nearest" | "margin" | "manipulability"}`` (and optionally its
    ``parameter``) on a 7-joint chain: the path moves along the self-motion, the parameter chosen
    continuously at each target for the objective
    (:func:`kinematics.algorithms.ik_path_redundant.self_motion_path`)."""
    options, rest = IKOptions.split(options, keywords)
    settings, avoid, wanted = options.settings, options.collisions, options.solutions
    query = Query.of(query, **rest)
    free = avoid.filter(query.robot, query.collision_pairs) if avoid is not None else None
    W, _ = pose_list(waypoints, "waypoints")
    link = query.frame_link()
    step = step or {}
    position = float(step.get("position", _ik_path.DEFAULT_STEP_POSITION))
    rotation = float(step.get("rotation", _ik_path.DEFAULT_STEP_ROTATION))
    motion = None
    if wanted.redundancy is not None:
        motion = _path_motion(query, link, wanted, settings)
        targets, _ = _ik_path.interpolate(W, position, rotation)
        locked_chain, locked_family = chain_and_family(query.robot, link, {**motion.locked, motion.joint: motion.v0})
        most, slices = most_solutions(query.robot, locked_chain, locked_family, "ignore"), \
            _ik_path_redundant.SLICES_PER_TARGET
        query.budget.check("max_ik_solutions", len(targets) * slices * most, field="step",
                           what=f"IK solutions ({len(targets)} targets x about {slices} slices of the self-motion "
                                f"x up to {most} each)")
    else:
        chain, family = chain_and_family(query.robot, link, wanted.locked_map)
        if family.closed_form:  # the path lists every in-limit solution of each of its targets first
            targets, _ = _ik_path.interpolate(W, position, rotation)
            check_solutions(query, len(targets), chain, family)
    q0 = None
    if seed is not None:
        S = query.seeds(seed, 1)
        if S.shape[0] != 1:
            raise JointValueError("seed: give one start configuration")
        q0 = S[0]
    B = query.base_poses(1)
    base = None if B is None else B.reshape(-1, 4, 4)[0]
    if motion is not None:
        return _ik_path_redundant.self_motion_path(motion, W, wanted.redundancy.select, q0, base=base,
                                                   step_position=position, step_rotation=rotation,
                                                   max_joint_step=max_joint_step, collision_free=free)
    return _ik_path.cartesian_path(query.robot, link, W, q0, base=base, tool=query.T_tool, locked=wanted.locked_map,
                                   step_position=position, step_rotation=rotation,
                                   max_joint_step=max_joint_step, position_tolerance=settings.position_tolerance,
                                   rotation_tolerance=settings.rotation_tolerance, collision_free=free)


def _path_motion(query: Query, link: str, wanted, settings) -> SelfMotion:
    """The self-motion a path with ``redundancy`` runs along (a redundant chain, a ``select``, no
    ``values`` or ``intervals``: bad ones are :class:`KinematicsError` s naming the field)."""
    spec = wanted.redundancy
    if spec.select is None or spec.values is not None or spec.intervals:
        raise KinematicsError("redundancy: a path takes select (nearest, margin or manipulability) and "
                              "optionally parameter; not values or intervals")
    if query.floating_base:
        raise KinematicsError("floating_base: a path along the self-motion needs a fixed base (give the base "
                              "pose as base)")
    return SelfMotion(query.robot, link, spec.parameter, locked=wanted.locked_map, tool=query.T_tool,
                      position_tolerance=settings.position_tolerance, rotation_tolerance=settings.rotation_tolerance)
