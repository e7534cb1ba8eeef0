"""Link velocities for joint values q and joint velocities qdot, in one pass down the tree."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..algorithms.velocity import twists_in_world, velocities as _velocities
from ..errors import JointValueError
from ..model.joint_values import as_velocity_batch
from ..model.robot import RobotModel
from ..spatial.reference import Reference
from .query import Answer, Query, Verification, joint_batch, prefixed


@dataclass(frozen=True, eq=False)
class VelocityAnswer(Answer):
    """Velocities of ``links`` for N configurations: ``twists[reference]`` (N, L, 6), linear part
    first; ``Qd`` (N, dof) the validated joint velocities."""

    Qd: np.ndarray
    links: list[str]
    twists: dict[Reference, np.ndarray]
    verification: Verification | None = None

    @property
    def linear(self) -> np.ndarray:
        """(N, L, 3) velocity of each link origin (or tool frame origin), world axes."""
        return self.twists[Reference.LOCAL_WORLD_ALIGNED][..., :3]

    @property
    def angular(self) -> np.ndarray:
        """(N, L, 3) angular velocity of each link, world axes."""
        return self.twists[Reference.LOCAL_WORLD_ALIGNED][..., 3:]


def velocity(query: Query | RobotModel, q: Any, qdot: Any, **options: Any) -> VelocityAnswer:
    """Velocities of the query's ``links`` (None or ``"all"``: every link; or names) for joint values
    ``q`` and joint velocities ``qdot`` (the same forms, one velocity vector per configuration),
    computed in one pass down the tree (:mod:`kinematics.algorithms.velocity`): per link the
    velocity of its origin and the angular velocity in world axes, and the twist in the three
    references.

    ``base``: the root link's world pose (at rest). ``point`` / ``tool``: the velocity of the frame
    at that offset from each link (as Pinocchio has it for a frame added there). ``verify``
    compares every twist with Pinocchio's ``getFrameVelocity``. ``qdot`` has ``nv`` entries (a
    floating joint's 6 are its twist in its own frame, linear first; a planar joint's 3 are
    ``vx, vy, ωz``).

    >>> from kinematics.io import default_catalogue
    >>> velocity(default_catalogue().get("ur5"), [0.0] * 6, [1.0, 0, 0, 0, 0, 0], links=["tool0"]).angular[0, 0]
    array([0., 0., 1.])
    """
    query = Query.of(query, **options)
    model, budget = query.robot, query.budget
    Q, is_batch = query.joints(q)
    try:
        if model.multi_dof:
            Qd, qd_batch = as_velocity_batch(model, qdot)
            budget.check_batch(Qd.shape[0])
        else:
            Qd, qd_batch = joint_batch(model, qdot, budget)
    except JointValueError as exc:
        raise prefixed(exc, "qdot: ") from None
    N = Q.shape[0]
    if Qd.shape[0] != N or qd_batch != is_batch:
        raise JointValueError(f"qdot: {Qd.shape[0]} velocity vector(s) for {N} configuration(s) of q: give one per "
                              "configuration, in the same form (a vector or a list of vectors)")
    names = query.link_names(default="all")
    query.check_sizes(N, N * len(names) * 18, f"{N} configurations x {len(names)} links x 3 twists x 6")
    B = query.base_poses(N)
    V = _velocities(model, Q, Qd, names, tool=query.T_tool)
    verification = None
    if query.verify:
        from ..verify.pinocchio import REFERENCE_NAME, compare_velocity

        err = compare_velocity(model, Q, Qd, names, twists=V, tool=query.T_tool)
        verification = Verification(REFERENCE_NAME, max_velocity_error=err)
    if B is not None:
        V = {ref: twists_in_world(v, B, ref) for ref, v in V.items()}
    return VelocityAnswer(model, Q, is_batch, Qd, names, V, verification)
