"""Inverse kinematics: joint values putting the query's link (or its point / tool frame) at targets."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..algorithms.ik import IKSolution
from ..model.robot import RobotModel
from ..errors import KinematicsError
from .ik_all import IKAllAnswer, ik_all
from .ik_options import IKOptions
from .ik_select import IKProblem, Selection, selection
from .ik_redundant import BestOverSelfMotion, ik_redundant
from .query import Query


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


def ik(query: Query | RobotModel, target: Any, *, seed: Any = None, options: IKOptions | None = None,
       select: Selection | None = None, **keywords: Any) -> IKAnswer | IKAllAnswer:
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

    ``options``: how to solve (:class:`~kinematics.usecases.ik_options.IKOptions`, built once), or
    its fields as keywords (``mode``, ``position_tolerance``, ``rotation_tolerance``,
    ``max_iterations``, ``restarts``, ``random_seed``; ``solutions``, ``method``, ``locked``,
    ``limits``, ``redundancy``; ``avoid_collisions``, ``collision_samples``, ``cache_dir``: :meth:`IKOptions.split`);
    the other keywords are the query's fields (:meth:`Query.of`).

    ``solutions="one"`` answers an :class:`IKAnswer`, one answer per target chosen by ``select``
    (a :class:`~kinematics.usecases.ik_select.Selection`; default
    :func:`~kinematics.usecases.ik_select.selection` of the options: with ``method="analytic"`` or
    ``locked`` joints the solution nearest the seed among all of them, else the numerical solver's).
    ``solutions="all"`` is :func:`kinematics.usecases.ik_all.ik_all`: **every** solution, an
    :class:`~kinematics.usecases.ik_all.IKAllAnswer` (``method`` ``auto`` / ``analytic`` /
    ``numeric``, ``locked`` ``{joint: value}``, ``limits`` ``respect`` / ``ignore``).

    ``avoid_collisions``: only answers free of self-collision (the enabled pairs of the model's
    allowed-collision matrix from ``collision_samples`` configurations, kept in ``cache_dir``; a
    model without collision geometry is a :class:`~kinematics.errors.CollisionError`). With
    ``solutions="all"`` the colliding solutions are left out (counted in ``colliding``); with
    ``"one"`` the search goes on where the answer collides -- for a chain with a closed form, the
    solution nearest the seed among the free ones of the full set; otherwise up to
    :data:`~kinematics.usecases.ik_select.COLLISION_ROUNDS` rounds of fresh seeds within the limits, each with its restarts --
    and ``success`` holds only for a free answer (``collision_free`` (N,) says which are).

    ``redundancy`` (a 7-joint chain): with ``solutions="all"`` its self-motion,
    :func:`kinematics.usecases.ik_redundant.ik_redundant` (with ``avoid_collisions``: the slices
    without their colliding solutions, or the best free point); with ``solutions="one"`` and its
    ``select``, the one best solution over the whole self-motion
    (:class:`~kinematics.usecases.ik_redundant.BestOverSelfMotion`).
    """
    options, rest = IKOptions.split(options, keywords)
    wanted = options.solutions
    if wanted.redundancy is not None:  # a 7-joint chain's self-motion (kinematics.usecases.ik_redundant)
        if wanted.solutions == "all":
            return ik_redundant(query, target, seed=seed, options=options, **rest)
        spec = wanted.redundancy
        if spec.select is None or spec.values is not None or spec.intervals:
            raise KinematicsError("redundancy: with solutions 'one' give select (the best point of the whole "
                                  "self-motion) and neither values nor intervals; or ask solutions 'all'")
        if select is None:
            select = BestOverSelfMotion(spec.select, spec.parameter)
    if wanted.solutions == "all":
        return ik_all(query, target, seed=seed, options=options, **rest)
    strategy = selection(options) if select is None else select
    problem = IKProblem.of(query, target, seed, options, rest, strategy)
    solution, free = strategy.select(problem)
    verification = None
    if problem.query.verify:  # every strategy's answer, checked against its target alike
        reference, position, rotation = problem.pinocchio_errors(solution.q, np.arange(len(problem.T)))
        verification = {"reference": reference, "position_error": position, "rotation_error": rotation}
    return IKAnswer(problem.model, problem.link, options.settings.mode, problem.is_batch, problem.T, solution,
                    verification, free)
