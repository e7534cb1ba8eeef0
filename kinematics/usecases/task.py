"""Task vectors ``r = (p, phi)`` and their analytic Jacobians ``J_r`` for joint values q."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from ..algorithms.measures import conditioning
from ..engine.poe import require_one_dof
from ..model.robot import RobotModel
from .query import Answer, Query, Verification


@dataclass(frozen=True, eq=False)
class TaskAnswer(Answer):
    """Task vectors ``r`` (N, m) and analytic Jacobians ``J_r`` (N, m, dof) of ``link``."""

    link: str
    representation: Any  # kinematics.algorithms.task.TaskRepresentation
    r: np.ndarray
    J_r: np.ndarray
    verification: Verification | None = None  # with verify: of the geometric Jacobian J_r is built from

    def conditioning(self) -> dict[str, np.ndarray]:
        """Singular values, manipulability and condition number of each ``J_r``."""
        return conditioning(self.J_r)


def task(query: Query | RobotModel, q: Any, *, representation: str = "rpy", components: Sequence[str] | None = None,
         **options: Any) -> TaskAnswer:
    """Task vectors ``r = (p, phi)`` of the query's ``link`` (None: the first leaf link) and their
    analytic Jacobians ``J_r = dr/dq = blockdiag(I, E(phi)^-1) J`` (:mod:`kinematics.algorithms.task`),
    for joint values ``q`` in the world of the query's ``base``; ``point`` / ``tool``: of the frame
    at that offset from the link (as :func:`~kinematics.usecases.fk.fk`); ``limits`` as there. At a
    singularity of the representation: :class:`~kinematics.errors.RepresentationSingularityError`.
    The Jacobian route's ``representation`` option answers this too. Models of one-dof joints only.
    ``verify``: Pinocchio has no analytic Jacobian, so the geometric one ``J_r`` is built from (the
    ``local_world_aligned`` Jacobian of :func:`~kinematics.usecases.jacobian.jacobian`) is checked.

    >>> from kinematics.io import default_catalogue
    >>> task(default_catalogue().get("ur5"), [0.1] * 6, link="tool0", representation="position").r.shape
    (1, 3)
    """
    from ..algorithms.task import task as _task, task_representation

    query = Query.of(query, **options)
    rep = task_representation(representation, components)
    model = query.robot
    require_one_dof(model, "task vectors")
    Q, is_batch = query.joints(q)
    link = query.frame_link()
    N = Q.shape[0]
    query.budget.check_result(N * rep.size * (model.dof + 1), f"{N} configurations x {rep.size} x ({model.dof} + 1)")
    r, J_r = _task(model, Q, link, rep, query.base_poses(N), query.T_tool)
    verification = None
    if query.verify:
        from ..spatial.reference import Reference
        from .jacobian import jacobian

        verification = jacobian(query.replace(link=link), q, reference=Reference.LOCAL_WORLD_ALIGNED).verification
    return TaskAnswer(model, Q, is_batch, link, rep, r, J_r, verification)
