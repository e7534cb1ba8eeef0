"""What the product computes from a model: FK, Jacobians, base poses, conditioning,
Denavit-Hartenberg forms (later: IK, closed forms, velocities, workspaces)."""

from .base import jacobian_in_world, poses_in_world
from .dh import dh_tool_pose, dh_transforms, urdf_to_dh
from .fk import forward_kinematics
from .jacobian import jacobian
from .measures import conditioning

__all__ = ["conditioning", "dh_tool_pose", "dh_transforms", "forward_kinematics", "jacobian", "jacobian_in_world",
           "poses_in_world", "urdf_to_dh"]
