"""Geometric Jacobians of the query's link (or of its point / tool frame) for joint values q."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..algorithms.base import jacobian_in_world
from ..algorithms.jacobian import jacobian as _jacobian
from ..algorithms.measures import conditioning
from ..model.robot import RobotModel
from ..spatial.reference import Reference
from .query import Answer, Query, Verification


@dataclass(frozen=True, eq=False)
class JacobianAnswer(Answer):
    link: str
    reference: Reference
    jacobians: np.ndarray  # (N, 6, dof), linear rows first
    verification: Verification | None = None

    def conditioning(self) -> dict[str, np.ndarray]:
        """Singular values, manipulability and condition number of each Jacobian."""
        return conditioning(self.jacobians)


def jacobian(query: Query | RobotModel, q: Any, *, reference: str = Reference.WORLD, **options: Any) -> JacobianAnswer:
    """Jacobians (N, 6, dof), linear rows first, of the query's ``link`` (None: the first leaf link)
    in ``reference``, for joint values ``q``, re-expressed in the world of the query's ``base``;
    with a ``point`` / ``tool``: the Jacobian of the frame at that offset from the link
    (Pinocchio's frame semantics, see :func:`kinematics.algorithms.jacobian.jacobian`); ``verify``
    and ``limits`` as :func:`~kinematics.usecases.fk.fk`. The columns follow the velocity vector
    (``nv``: 6 per floating joint, 3 per planar joint).

    >>> from kinematics.io import default_catalogue
    >>> jacobian(default_catalogue().get("ur5"), [0.0] * 6, link="tool0", reference="local").jacobians.shape
    (1, 6, 6)
    """
    query = Query.of(query, **options)
    model = query.robot
    Q, is_batch = query.joints(q)
    link = query.frame_link()
    N = Q.shape[0]
    query.check_sizes(N, N * 6 * model.dof, f"{N} configurations x 6 x {model.dof}")
    B = query.base_poses(N)
    J = _jacobian(model, Q, link, reference, tool=query.T_tool)
    verification = None
    if query.verify:
        from ..verify.pinocchio import REFERENCE_NAME, compare_jacobian

        err = compare_jacobian(model, Q, link, references=(reference,), jacobians={reference: J}, tool=query.T_tool)
        verification = Verification(REFERENCE_NAME, max_jacobian_error=err)
    return JacobianAnswer(model, Q, is_batch, link, Reference(reference), jacobian_in_world(J, B, reference),
                          verification)
