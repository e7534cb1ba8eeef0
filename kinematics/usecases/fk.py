"""Forward kinematics: poses ``T_world_link`` of the query's links for joint values q."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..algorithms.base import poses_in_world
from ..algorithms.fk import forward_kinematics
from ..model.robot import RobotModel
from ..spatial.transforms import pose_components
from .query import Answer, Query, Verification


@dataclass(frozen=True, eq=False)
class FKAnswer(Answer):
    links: list[str]
    poses: np.ndarray  # (N, L, 4, 4) T_world_link
    verification: Verification | None = None

    def components(self) -> dict[str, np.ndarray]:
        """``position`` (N, L, 3), ``quaternion`` (N, L, 4, w first) and ``rpy`` (N, L, 3) of the poses."""
        return pose_components(self.poses)


def fk(query: Query | RobotModel, q: Any, **options: Any) -> FKAnswer:
    """Poses ``T_world_link`` (N, L, 4, 4) of the query's ``links`` (None: the leaf links; ``"all"``;
    or names) for joint values ``q`` (a vector, a name map, or a list of those), in the world of
    the query's ``base``. With a ``point`` or ``tool`` the poses are those of that frame,
    ``T_world_link @ T_link_tool``, on every link returned. ``verify`` compares the poses (in the
    root frame) with Pinocchio's; ``limits="refuse"`` raises :class:`LimitError`.
    ``fk(model, q, links=...)`` builds the :class:`Query` from the keywords (:meth:`Query.of`).

    >>> from kinematics.io import default_catalogue
    >>> answer = fk(default_catalogue().get("ur5"), [0.0] * 6, links=["tool0"])
    >>> answer.poses.shape, answer.is_batch, answer.out_of_limits()
    ((1, 1, 4, 4), False, [[]])
    >>> answer.poses[0, 0, :3, 3].round(6)
    array([ 0.81725 ,  0.19145 , -0.005491])
    """
    query = Query.of(query, **options)
    model = query.robot
    Q, is_batch = query.joints(q)
    names = query.link_names()
    N = Q.shape[0]
    query.check_sizes(N, N * len(names) * 16, f"{N} configurations x {len(names)} links x 16")
    B = query.base_poses(N)
    T = forward_kinematics(model, Q, names, tool=query.T_tool)
    verification = None
    if query.verify:
        from ..verify.pinocchio import compare_fk

        dev = compare_fk(model, Q, names, poses=T, tool=query.T_tool)
        verification = Verification(dev.reference, max_position_error=dev.max_position_error,
                                    max_rotation_error=dev.max_rotation_error)
    return FKAnswer(model, Q, is_batch, names, poses_in_world(T, B), verification)
