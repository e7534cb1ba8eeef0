"""Wire schemas of forward kinematics (``POST /models/{id}/fk``)."""

from __future__ import annotations

from typing import Any, Literal, Union

from pydantic import BaseModel, Field

from kinematics.io.pose_records import pose_output

from .common import UR5_HOME, JointsRequest, Matrix, PoseFormat, Quaternion, Vector, one_or_all

class Pose(BaseModel):
    matrix: Matrix = Field(description="T_world_link, 4x4 row-major")
    position: Vector = Field(description="p_world_link, metres")
    quaternion: Quaternion = Field(description="rotation of T_world_link, unit quaternion")
    rpy: Vector = Field(description="roll, pitch, yaw (URDF: R = Rz(yaw) Ry(pitch) Rx(roll))")


class CompactPoses(BaseModel):
    positions: list[Vector] = Field(description="(N, 3) positions, one row per configuration")
    quaternions: list[Vector] = Field(description="(N, 4) unit quaternions, w first (w, x, y, z)")


class FKVerification(BaseModel):
    reference: str = Field(examples=["pinocchio 4.1.0"])
    max_position_error: float = Field(description="metres, over every configuration and link returned")
    max_rotation_error: float = Field(description="largest rotation-matrix entry difference")



class FKRequest(JointsRequest):
    links: Union[Literal["all"], list[str], None] = Field(
        default=None, description='link names; "all" for every link; default: the leaf links')
    format: PoseFormat = Field(
        default="pose",
        description="pose: matrix, position, quaternion, rpy per link; matrix: the 4x4 only; "
                    "compact: per link positions (N,3) and quaternions (N,4, w first) arrays")


class FKResponse(BaseModel):
    model: str
    joint_names: list[str]
    links: list[str] = Field(description="the links returned, in order")
    format: PoseFormat
    poses: Union[dict[str, Pose], list[dict[str, Pose]], dict[str, Matrix], list[dict[str, Matrix]],
                 dict[str, CompactPoses]] = Field(
        description="per link (pose: Pose, matrix: 4x4, compact: arrays); for a batch with format "
                    "pose or matrix, a list with one entry per configuration")
    out_of_limits: Union[list[str], list[list[str]]] = Field(
        description="joints outside their limits (for a batch, one list per configuration)")
    verification: FKVerification | None = None

    @staticmethod
    def content(model_id: str, answer: Any, format: str) -> dict[str, Any]:
        """The JSON answer of a :class:`kinematics.FKAnswer` in pose ``format`` (a single configuration
        unwrapped)."""
        one = one_or_all(answer.is_batch)
        verification = answer.verification
        return {
            "model": model_id, "joint_names": list(answer.model.joint_names), "links": answer.links, "format": format,
            "poses": pose_output(answer.poses, answer.links, format, answer.is_batch),
            "out_of_limits": one(answer.out_of_limits()),
            "verification": verification.as_dict() if verification else None,
        }


FK_EXAMPLES = {
    "ur5_single": {
        "summary": "UR5, one configuration",
        "value": {"q": UR5_HOME, "links": ["tool0"], "verify": True},
    },
    "ur5_batch": {
        "summary": "UR5, a batch of two",
        "value": {"q": [[0, 0, 0, 0, 0, 0], UR5_HOME], "links": ["tool0", "wrist_3_link"]},
    },
    "ur5_name_map": {
        "summary": "UR5, q as a name map, every link",
        "value": {"q": {"shoulder_pan_joint": 0.1, "shoulder_lift_joint": -1.2, "elbow_joint": 1.0,
                        "wrist_1_joint": 0.0, "wrist_2_joint": 1.57, "wrist_3_joint": 0.0}, "links": "all"},
    },
    "ur5_compact": {
        "summary": "UR5, a batch in compact form",
        "value": {"q": [[0, 0, 0, 0, 0, 0], UR5_HOME], "format": "compact"},
    },
}
