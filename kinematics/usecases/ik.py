"""Inverse kinematics: joint values putting the query's link (or its point / tool frame) at targets."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..algorithms import ik as _ik
from ..algorithms.ik import IKSolution, inverse_kinematics, pose_errors
from ..errors import KinematicsError
from ..model.robot import RobotModel
from ..spatial.transforms import inverse_transform
from .ik_all import SOLUTIONS, ik_all
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


def ik(query: Query | RobotModel, target: Any, *, seed: Any = None, mode: str = "pose",
       position_tolerance: float = _ik.DEFAULT_POSITION_TOLERANCE,
       rotation_tolerance: float = _ik.DEFAULT_ROTATION_TOLERANCE,
       max_iterations: int = _ik.DEFAULT_MAX_ITERATIONS, restarts: int = _ik.DEFAULT_RESTARTS,
       random_seed: int = 0, solutions: str = "one", method: str = "auto", locked: dict | None = None,
       limits: str = "respect", **options: Any):
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
    """
    if solutions not in SOLUTIONS:
        raise KinematicsError(f"solutions: {solutions!r} is not one of {', '.join(SOLUTIONS)}")
    if method not in ("auto", "analytic", "numeric"):
        raise KinematicsError(f"method: {method!r} is not one of auto, analytic, numeric")
    if solutions == "all" or method == "analytic" or locked:
        answer = ik_all(query, target, seed=seed, mode=mode, position_tolerance=position_tolerance,
                        rotation_tolerance=rotation_tolerance, method=method, locked=locked, limits=limits,
                        one=solutions == "one", max_iterations=max_iterations, restarts=restarts,
                        random_seed=random_seed, **options)
        if solutions == "all":
            return answer
        link, T, is_batch, solution = answer
        return IKAnswer(Query.of(query, **options).robot, link, mode, is_batch, T, solution)
    query = Query.of(query, **options)
    model, budget = query.robot, query.budget
    T, is_batch = query.targets(target)
    N = T.shape[0]
    budget.check_ik_work(N, restarts, max_iterations)
    link = query.frame_link()
    seeds = query.seeds(seed, N)
    B = query.base_poses(N)
    B = None if B is None else np.ascontiguousarray(B)
    T_tool = query.T_tool
    solution = inverse_kinematics(model, link, T, seeds, base=B, mode=mode, position_tolerance=position_tolerance,
                                  rotation_tolerance=rotation_tolerance, max_iterations=max_iterations,
                                  restarts=restarts, random_seed=random_seed, tool=T_tool)
    verification = None
    if query.verify:
        from ..verify.pinocchio import REFERENCE_NAME, reference_for

        frames = reference_for(model).frames([link], T_tool)
        theirs = np.array([frames.poses(q)[link] for q in solution.q]).reshape(N, 4, 4)
        T_root = T if B is None else np.matmul(inverse_transform(B), T)
        position, rotation = pose_errors(theirs, T_root)
        verification = {"reference": REFERENCE_NAME, "position_error": position, "rotation_error": rotation}
    return IKAnswer(model, link, mode, is_batch, T, solution, verification)
