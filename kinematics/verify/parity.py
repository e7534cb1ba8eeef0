"""Catalogue-wide parity with Pinocchio (what ``kinematics check`` and the tests run).

For each model: random configurations inside the limits (continuous joints drawn beyond
+-pi), FK of every link, the three Jacobians of every leaf link, and the velocity of every
link in the three references (random joint velocities in [-1, 1]; Pinocchio's
``forwardKinematics(q, v)`` and ``getFrameVelocity``), compared with Pinocchio. A model Pinocchio (or our parser) refuses is reported as ``refused`` with the
error message and not counted in the total.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import KinematicsError
from ..model.robot import RobotModel
from ..tolerances import AGREEMENT_TOLERANCE
from .pinocchio import compare_fk, compare_jacobian, compare_velocity, reference_for


@dataclass(frozen=True)
class ParityResult:
    model_id: str
    status: str  # ok | FAIL | refused
    dof: int = 0
    links: int = 0
    position_error: float = 0.0
    rotation_error: float = 0.0
    jacobian_error: float = 0.0
    velocity_error: float = 0.0
    message: str = ""

    @property
    def worst(self) -> float:
        return max(self.position_error, self.rotation_error, self.jacobian_error, self.velocity_error)


def check_model(model_id: str, load, samples: int = 5, seed: int = 0, tolerance: float = AGREEMENT_TOLERANCE) -> ParityResult:
    """Compare one model with Pinocchio; ``load()`` returns the :class:`RobotModel`."""
    try:
        model: RobotModel = load()
        reference_for(model)
    except KinematicsError as exc:
        return ParityResult(model_id, "refused", message=str(exc))
    rng = np.random.default_rng(seed)
    Q = model.sample_configurations(samples, rng)
    fk = compare_fk(model, Q)
    jac = max((compare_jacobian(model, Q, leaf) for leaf in model.leaf_links), default=0.0)
    Qd = rng.uniform(-1.0, 1.0, (Q.shape[0], model.nv))
    vel = compare_velocity(model, Q, Qd)
    res = ParityResult(
        model_id, "ok", model.dof, len(model.links), fk.max_position_error, fk.max_rotation_error, jac, vel
    )
    if not res.worst <= tolerance:
        res = ParityResult(model_id, "FAIL", res.dof, res.links, res.position_error, res.rotation_error,
                           res.jacobian_error, res.velocity_error)
    return res


def summary_line(results: list[ParityResult], tolerance: float = AGREEMENT_TOLERANCE) -> str:
    """``parity: <ok>/<total> models within 1e-09 (worst <value>)``; refused models are not counted."""
    counted = [r for r in results if r.status != "refused"]
    ok = sum(r.status == "ok" for r in counted)
    worst = max((r.worst for r in counted), default=0.0)
    return f"parity: {ok}/{len(counted)} models within {tolerance:.0e} (worst {worst:.3e})"
