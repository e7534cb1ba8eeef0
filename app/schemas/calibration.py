"""Wire schemas of calibration: ``POST /models/{id}/calibrate`` and ``POST /models/{id}/calibration/poses``.

The requests build their :class:`kinematics.Query` from ``link``, ``point`` and ``verify``
(:class:`~app.schemas.common.ToQuery`); ``base`` and ``tool`` here are what the calibration does
with the device frame and the tool (estimate them, or hold them), not poses of the query."""

from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import BaseModel, ConfigDict, Field

from .calibration_example import UR5_MEASUREMENTS
from .common import BasePose, BasePositionQuaternion, Flag, Integer, JointMap, JointVector, Finite, Number, Point, ToQuery

_MEASURE_Q = "the joint values of the measurement: a vector in the model's joint order or a {joint: value} map"


class PositionMeasurement(BaseModel):
    model_config = ConfigDict(extra="forbid")
    q: Union[JointVector, JointMap] = Field(description=_MEASURE_Q)
    position: Point = Field(description="where the device saw the marker, metres, in the device's frame")


class PoseMeasurement(BaseModel):
    model_config = ConfigDict(extra="forbid")
    q: Union[JointVector, JointMap] = Field(description=_MEASURE_Q)
    pose: BasePose = Field(description="the tool's pose as the device saw it (T_device_tool)")


class ComplianceOption(BaseModel):
    model_config = ConfigDict(extra="forbid")
    joints: Union[list[str], None] = Field(default=None, description="the joints given a compliance (default every "
                                                                    "moving joint on the path)")
    gravity: Union[Point, None] = Field(default=None, description="the gravity vector in the root frame, m/s^2 "
                                                                  "(default [0, 0, -9.81])")


class PriorOption(BaseModel):
    model_config = ConfigDict(extra="forbid")
    length: Finite = Field(default=0.01, gt=0.0, description="standard deviation of a joint origin's translation, m")
    angle: Finite = Field(default=0.02, gt=0.0, description="of a joint origin's rotation and of a zero offset, rad")
    compliance: Finite = Field(default=0.005, gt=0.0, description="of a joint compliance, rad/(N m)")
    noise: Union[Finite, None] = Field(default=None, gt=0.0, description="the measurement noise, m (default: the "
                                                                         "spread of the plain fit's residuals)")


class CalibrationRequest(ToQuery, BaseModel):
    model_config = ConfigDict(extra="forbid")
    link: Union[str, None] = Field(default=None, description="the link the marker or tool is fixed to (default: the "
                                                             "model's first leaf link, as on every operation)")
    measurements: Union[Annotated[list[PositionMeasurement], Field(min_length=1)],
                        Annotated[list[PoseMeasurement], Field(min_length=1)]] = Field(
        description="what the device measured: every entry a position, or every entry a pose")
    point: Union[Point, None] = Field(default=None, description="a guess of the marker point on the link, metres "
                                      "(positions; default the link origin: the fit starts from the best point anyway)")
    parameters: Literal["full", "joint_offsets"] = Field(
        default="full", description="full: every joint origin on the path (3 translations, 3 rotations) and zero "
                                    "offset; joint_offsets: the zeros only")
    base: Union[Literal["estimate", "fixed"], BasePose] = Field(
        default="estimate", description="the device frame T_device_root: estimate (no guess needed), fixed (the "
                                        "device frame is the root frame) or a pose (fixed there)")
    tool: Literal["estimate", "fixed"] = Field(default="estimate", description="estimate or keep the marker point / tool")
    loss: Literal["linear", "huber"] = Field(
        default="linear", description="huber: robust; the measurements beyond the residuals' chi-square 99.99 % bound "
                                      "are named outliers and left out of the final fit")
    holdout: Finite = Field(default=0.0, ge=0.0, lt=1.0, description="fraction of the measurements kept out of the "
                                                                     "fit; their RMS is reported (holdout_rmse)")
    random_seed: Integer = Field(default=0, ge=0, le=2**63 - 1, description="which measurements are held out")
    rotation_weight: Finite = Field(default=1.0, gt=0.0, le=1e3, description="metres per radian of a rotation "
                                                                           "residual (poses): 1 weighs 1 mrad as 1 mm")
    name: Union[str, None] = Field(default=None, max_length=200, description="the calibrated model's name")
    compliance: Union[Flag, ComplianceOption, None] = Field(
        default=None, description="true or {joints, gravity}: estimate each joint's compliance under gravity too (its "
                                  "value lags by c times the torque it holds, from the URDF's masses; <joint>.compliance "
                                  "in parameters; the calibrated URDF holds the geometric corrections only)")
    prior: Union[Flag, PriorOption, None] = Field(
        default=None, description="true or {length, angle, compliance, noise}: a maximum a posteriori fit, every "
                                  "joint parameter held near nominal within these standard deviations")
    verify: Flag = Field(default=False, description="also compare the calibrated model's FK with Pinocchio's on the "
                                                    "measured configurations (verification)")

    def fit_fields(self) -> dict:
        """How the fit goes, as the use case's keywords (it builds its FitOptions once from them)."""
        fields = {k: getattr(self, k) for k in ("parameters", "base", "tool", "loss", "holdout", "random_seed",
                                                "rotation_weight", "compliance", "prior")}
        for key in ("compliance", "prior"):  # true, false, null or the option's fields
            value = fields[key]
            fields[key] = value.model_dump() if hasattr(value, "model_dump") else value
        return fields


class CalibrationParameter(BaseModel):
    name: str = Field(examples=["elbow_joint.offset"])
    value: float = Field(description="metres or radians")
    sigma: float = Field(description="standard deviation, from the Jacobian at the solution and the residual variance")


class Unidentifiable(BaseModel):
    name: str
    reason: str = Field(examples=["absorbed by the base frame"])


class Residuals(BaseModel):
    before: list[float] = Field(description="per measurement, metres: the nominal model (registered)")
    after: list[float] = Field(description="per measurement, metres: the calibrated model")


class CalibrationResponse(BaseModel):
    model: str = Field(description="the id of the calibrated model (registered like an upload)")
    from_: str = Field(alias="from", description="the id of the nominal model")
    link: str
    measure: Literal["position", "pose"]
    base: BasePositionQuaternion = Field(description="T_device_root: pass it as the base of FK requests on the "
                                                     "calibrated model")
    point: Union[list[float], None] = Field(default=None, description="the marker point on the link (positions)")
    tool: Union[BasePositionQuaternion, None] = Field(default=None, description="T_link_tool (poses)")
    identifiable: int
    parameters: list[CalibrationParameter]
    unidentifiable: list[Unidentifiable]
    condition_number: float
    rmse_before: float
    rmse_after: float
    max_before: float
    max_after: float
    rotation_rmse_before: Union[float, None] = None
    rotation_rmse_after: Union[float, None] = None
    outliers: list[int]
    holdout: list[int]
    holdout_rmse: Union[float, None]
    iterations: int
    residuals: Residuals
    verification: Union[dict, None] = Field(default=None, description="with verify: reference, max_position_error, "
                                                                      "max_rotation_error of the calibrated model")


class CalibrationPosesRequest(ToQuery, BaseModel):
    model_config = ConfigDict(extra="forbid")
    link: Union[str, None] = Field(default=None, description="the link the marker will be on (default: the model's "
                                                             "first leaf link)")
    n: Integer = Field(ge=1, le=200, description="how many configurations (up to 200 over HTTP: the selection's time "
                                                 "grows with n; the library takes up to 1000)")
    measure: Literal["position", "pose"] = "position"
    random_seed: Integer = Field(default=0, ge=0, le=2**63 - 1)
    point: Union[Point, None] = Field(default=None, description="where the marker will be on the link (default "
                                                                "0.05 0.05 0.05 m: off the last axis)")
    parameters: Literal["full", "joint_offsets"] = "full"


class CalibrationPosesResponse(BaseModel):
    joint_names: list[str]
    q: list[list[float]]
    measure: dict = Field(description="criterion (D-optimality), log_det, condition_number, identifiable, and the "
                                      "same for n random configurations (random_log_det, random_condition_number)")


CALIBRATION_EXAMPLES = {
    "ur5_positions": {"summary": "ur5: 30 marker positions, huber loss, 20 % held out",
                      "value": {"link": "tool0", "loss": "huber", "holdout": 0.2, "measurements": UR5_MEASUREMENTS}},
}
CALIBRATION_POSES_EXAMPLES = {
    "ur5_30": {"summary": "ur5: 30 configurations to measure a marker on tool0",
               "value": {"link": "tool0", "n": 30, "measure": "position", "random_seed": 0}},
}

__all__ = ["PositionMeasurement", "PoseMeasurement", "CalibrationRequest", "CalibrationParameter", "Unidentifiable",
           "Residuals", "CalibrationResponse", "CalibrationPosesRequest", "CalibrationPosesResponse",
           "CALIBRATION_EXAMPLES", "CALIBRATION_POSES_EXAMPLES"]
