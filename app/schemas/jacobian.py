"""Wire schemas of Jacobians (``POST /models/{id}/jacobian``), geometric or analytic."""

from __future__ import annotations

from typing import Any, Union

import numpy as np
from kinematics.errors import KinematicsError
from pydantic import BaseModel, Field, model_validator

from kinematics.spatial.reference import Reference

from .common import UR5_HOME, JointsRequest, Matrix, References, TaskRepresentationName, Vector, one_or_all

class JacobianVerification(BaseModel):
    reference: str
    max_jacobian_error: float = Field(description="largest entry-wise difference")



_ANALYTIC_DESC = ("the analytic Jacobian J_r = dr/dq of this task vector instead of the geometric one "
                  "(POST /models/{id}/task's use case): jacobian is m x dof and r is given; reference must be "
                  "absent or local_world_aligned (J_r is built from that one), and verify checks that geometric "
                  "Jacobian with Pinocchio (which has no analytic one)")


class JacobianRequest(JointsRequest):
    link: str | None = Field(default=None, description="default: the first leaf link")
    reference: References = Field(default=Reference.WORLD, description="world | local | local_world_aligned (Pinocchio's meaning)")
    representation: Union[TaskRepresentationName, None] = Field(default=None, description=_ANALYTIC_DESC)
    components: list[str] | None = Field(default=None, description="with representation: keep these components "
                                         "of the task vector (default all)")

    @model_validator(mode="after")
    def _analytic_reference(self):
        if "reference" in self.model_fields_set:
            check_analytic_reference(self.reference, self.representation, self.components)
        return self


def check_analytic_reference(reference: Reference | None, representation: str | None,
                             components: list[str] | None) -> None:
    """An analytic Jacobian (``representation`` or ``components``) is built from the
    local_world_aligned Jacobian: another ``reference`` asked for with it is refused, never changed."""
    if reference is not None and (representation is not None or components is not None) \
            and Reference(reference) is not Reference.LOCAL_WORLD_ALIGNED:
        # a KinematicsError, not a ValueError: the request is well formed, the combination is refused (422)
        raise KinematicsError(f"reference {Reference(reference).value!r} with representation: the analytic Jacobian "
                         "J_r = dr/dq is built from the local_world_aligned Jacobian; leave reference out (or give "
                         "local_world_aligned), or leave representation out for the geometric Jacobian in "
                         f"{Reference(reference).value}")


class JacobianResponse(BaseModel):
    model: str
    link: str
    reference: References
    joint_names: list[str] = Field(description="the order of the columns")
    jacobian: Union[Matrix, list[Matrix]] = Field(description="6 x dof, linear rows first (batch: one per configuration); "
                                                  "with representation: J_r = dr/dq, m x dof, rows as components")
    singular_values: Union[Vector, list[Vector]]
    manipulability: Union[float, list[float]] = Field(description="product of the singular values")
    condition_number: Union[float, None, list[Union[float, None]]] = Field(
        description="largest / smallest singular value; null at a singularity (infinite)")
    out_of_limits: Union[list[str], list[list[str]]]
    verification: JacobianVerification | None = None
    representation: str | None = Field(default=None, description="with representation: its name")
    components: list[str] | None = Field(default=None, description="with representation: the rows of jacobian and r")
    r: Union[Vector, list[Vector], None] = Field(default=None, description="with representation: the task vector")

    @staticmethod
    def content(model_id: str, answer: Any) -> dict[str, Any]:
        """The JSON answer of a :class:`kinematics.JacobianAnswer` (a single configuration unwrapped)."""
        one = one_or_all(answer.is_batch)
        return {"model": model_id, "link": answer.link, "reference": answer.reference.value,
                "joint_names": list(answer.model.joint_names), "jacobian": one(answer.jacobians),
                **_conditioning(answer, one), "out_of_limits": one(answer.out_of_limits()),
                "verification": _verification(answer)}

    @staticmethod
    def analytic_content(model_id: str, answer: Any) -> dict[str, Any]:
        """The JSON answer of a :class:`kinematics.TaskAnswer` given as an analytic Jacobian (``representation``):
        ``J_r`` in ``jacobian`` and ``r``, built from the local_world_aligned Jacobian (which it names)."""
        one = one_or_all(answer.is_batch)
        return {"model": model_id, "link": answer.link, "reference": Reference.LOCAL_WORLD_ALIGNED.value,
                "representation": answer.representation.name, "components": list(answer.representation.labels),
                "joint_names": list(answer.model.joint_names), "jacobian": one(answer.J_r),
                "r": one(answer.r), **_conditioning(answer, one), "out_of_limits": one(answer.out_of_limits()),
                "verification": _verification(answer)}


def _conditioning(answer: Any, one) -> dict[str, Any]:
    """Singular values, manipulability and condition number (null at a singularity) of an answer's Jacobians."""
    measures = answer.conditioning()
    cond = [None if not np.isfinite(c) else float(c) for c in measures["condition_number"]]
    return {"singular_values": one(measures["singular_values"]), "manipulability": one(measures["manipulability"].tolist()),
            "condition_number": one(cond)}


def _verification(answer: Any) -> dict[str, Any] | None:
    return answer.verification.as_dict() if answer.verification else None


JACOBIAN_EXAMPLES = {
    "ur5_world": {
        "summary": "UR5 tool0, world reference, verified",
        "value": {"q": UR5_HOME, "link": "tool0", "reference": "world", "verify": True},
    },
    "ur5_batch_lwa": {
        "summary": "UR5, a batch, local_world_aligned",
        "value": {"q": [[0, 0, 0, 0, 0, 0], UR5_HOME], "link": "tool0", "reference": "local_world_aligned"},
    },
    "ur5_analytic_rpy": {
        "summary": "UR5 tool0, analytic Jacobian of (px, py, pz, roll, pitch, yaw)",
        "value": {"q": [0, -1.2, 1.5, -0.4, 1.1, 0.3], "link": "tool0", "representation": "rpy"},
    },
}
