"""SO(3) and SE(3): rotation conversions, rigid transforms, exponentials of screws, and the
names of the reference frames. Knows nothing of robots."""

from .reference import REFERENCES, Reference
from .rotations import matrix_to_quaternion, matrix_to_rpy, matrix_to_rpy_exact, quaternion_to_matrix, rpy_to_matrix, skew
from .transforms import exp_screws, inverse_transform, is_rigid_transform, make_transform, pose_components

__all__ = ["REFERENCES", "Reference", "exp_screws", "inverse_transform", "is_rigid_transform", "make_transform", "pose_components",
           "matrix_to_quaternion", "matrix_to_rpy", "matrix_to_rpy_exact", "quaternion_to_matrix", "rpy_to_matrix", "skew"]
