"""The immutable robot model: links, joints and their kinds, the layout of q, and limits."""

from .joint_values import as_batch, limit_violations, out_of_limits, require_within_limits
from .robot import MOVING_TYPES, SUPPORTED_TYPES, Joint, Limits, Mimic, RobotModel, Visual, frozen_array

__all__ = ["MOVING_TYPES", "SUPPORTED_TYPES", "Joint", "Limits", "Mimic", "RobotModel", "Visual", "as_batch",
           "frozen_array", "limit_violations", "out_of_limits", "require_within_limits"]
