"""Wire schemas of link velocities (``POST /models/{id}/velocity``)."""

from __future__ import annotations

from typing import Literal, Union

from pydantic import BaseModel, Field

from .common import UR5_HOME, JointValues, JointsRequest, Vector


class VelocityRequest(JointsRequest):
    qdot: JointValues = Field(description="joint velocities (rad/s, m/s), in the same form as q: one vector or map "
                                          "per configuration; a mimic joint moves with multiplier * its leader's")
    links: Union[Literal["all"], list[str], None] = Field(default=None, description='link names; default (or "all"): every link')


class Twists(BaseModel):
    world: Vector = Field(description="twist of the body at the world origin, world axes (linear first)")
    local: Vector = Field(description="velocity of the link origin and angular velocity in the link's axes")
    local_world_aligned: Vector = Field(description="velocity of the link origin and angular velocity, world axes")


class LinkVelocity(BaseModel):
    linear: Vector = Field(description="velocity of the link origin (or of the point / tool origin), world axes, m/s")
    angular: Vector = Field(description="angular velocity of the link, world axes, rad/s")
    twist: Twists


class VelocityVerification(BaseModel):
    reference: str = Field(examples=["pinocchio 4.1.0"])
    max_velocity_error: float = Field(description="largest entry-wise difference of the twists (three references)")


class VelocityResponse(BaseModel):
    model: str
    joint_names: list[str]
    links: list[str] = Field(description="the links returned, in order")
    velocities: Union[dict[str, LinkVelocity], list[dict[str, LinkVelocity]]] = Field(
        description="per link; for a batch, a list with one map per configuration")
    out_of_limits: Union[list[str], list[list[str]]]
    verification: VelocityVerification | None = None


VELOCITY_EXAMPLES = {
    "ur5_tool": {"summary": "UR5 tool0 turning the shoulder, verified",
                 "value": {"q": UR5_HOME, "qdot": [0.5, 0, 0, 0, 0, 0], "links": ["tool0"], "verify": True}},
    "ur5_tcp_batch": {"summary": "a TCP 10 cm along tool0's z, a batch of two",
                      "value": {"q": [[0, 0, 0, 0, 0, 0], UR5_HOME], "qdot": [[0, 1, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0]],
                                "links": ["tool0"], "point": [0, 0, 0.1]}},
}

