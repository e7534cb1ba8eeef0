"""Wire schemas of trajectories (``POST /models/{id}/trajectory``)."""

from __future__ import annotations

from typing import Literal, Union

from pydantic import BaseModel, ConfigDict, Field

from .common import JointValues, Number, Vector

#: a limit: one number for every joint, or one per joint (joint_names order)
LimitValue = Union[Number, list[Number]]


class ToolSpeedLimit(BaseModel):
    model_config = ConfigDict(extra="forbid")
    link: str = Field(description="the link whose origin (or point) is limited")
    max: Number = Field(description="the largest linear speed, m/s, world axes")
    point: Union[list[Number], None] = Field(default=None, description="[x, y, z] in the link frame (default: its origin)")


class TrajectoryLimitsIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    velocity: Union[LimitValue, None] = Field(default=None, description="rad/s or m/s; default: the model's "
                                                                        "<limit velocity> (required where it has none)")
    acceleration: Union[LimitValue, None] = Field(default=None, description="rad/s^2 or m/s^2: required")
    jerk: Union[LimitValue, None] = Field(default=None, description="rad/s^3 or m/s^3: a jerk-limited trajectory")
    tool_speed: Union[ToolSpeedLimit, None] = None


class TrajectoryRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    waypoints: JointValues = Field(description="two or more configurations (vectors or name maps), e.g. the q of "
                                               "an /ik/path answer")
    interpolation: Literal["spline", "linear"] = Field(
        default="spline", description='"spline": scipy.interpolate.CubicSpline(np.linspace(0, 1, M), waypoints) '
                                      '(not-a-knot); "linear": straight segments, blends within `blend` of corners')
    blend: Number = Field(default=0.0, description="linear: the largest distance (joint-space norm) of a blend "
                                                   "from its corner; 0 stops at each corner")
    limits: TrajectoryLimitsIn
    rate: Number = Field(default=100.0, description="samples per second, 0 < rate <= 100 kHz (t in steps of 1/rate, "
                                                    "the last sample at the duration)")


class TrajectoryLimitsOut(BaseModel):
    velocity: Vector
    acceleration: Vector
    jerk: Union[Vector, None] = None
    tool_speed: Union[dict, None] = None


class TrajectoryResponse(BaseModel):
    model: str
    joint_names: list[str]
    duration: float = Field(description="seconds")
    method: str
    interpolation: str
    optimal_duration: Union[float, None] = Field(
        default=None, description="with jerk: the time-optimal duration under velocity and acceleration alone")
    limits: TrajectoryLimitsOut = Field(description="the limits used, per joint")
    t: list[float] = Field(description="sample times, s")
    q: list[Vector]
    qd: list[Vector]
    qdd: list[Vector]


TRAJECTORY_EXAMPLES = {
    "ur5_spline": {"summary": "UR5 through three configurations, time-optimal",
                   "value": {"waypoints": [[0, -1.57, 1.57, 0, 1.57, 0], [0.5, -1.2, 1.2, 0.3, 1.57, 0],
                                           [1.0, -1.0, 0.8, 0, 1.2, 0.5]],
                             "limits": {"acceleration": 3.0}, "rate": 50}},
    "ur5_linear_jerk": {"summary": "straight segments with 0.1 rad blends, jerk-limited, tool at most 0.5 m/s",
                        "value": {"waypoints": [[0, -1.57, 1.57, 0, 1.57, 0], [0.5, -1.2, 1.2, 0.3, 1.57, 0],
                                                [1.0, -1.0, 0.8, 0, 1.2, 0.5]],
                                  "interpolation": "linear", "blend": 0.1,
                                  "limits": {"velocity": 1.0, "acceleration": 3.0, "jerk": 30.0,
                                             "tool_speed": {"link": "tool0", "max": 0.5}}, "rate": 50}},
}

__all__ = ["ToolSpeedLimit", "TrajectoryLimitsIn", "TrajectoryRequest", "TrajectoryLimitsOut", "TrajectoryResponse",
           "TRAJECTORY_EXAMPLES"]
