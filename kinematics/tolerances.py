"""Tolerances and bounds shared by every layer of the library (one name for each).

They are numbers the product promises or relies on; a module that needs one imports it
from here rather than writing the literal again.
"""

from __future__ import annotations

#: The agreement the product promises with the reference (Pinocchio) and with the closed
#: forms: metres for positions, plain numbers for rotation and Jacobian entries.
AGREEMENT_TOLERANCE = 1e-9
#: Joint values within this distance of a limit count as inside it.
LIMIT_TOLERANCE = 1e-12
#: How far a given rotation may be from orthonormal (or a quaternion from unit length)
#: before a pose in a request or a table is refused as not rigid.
RIGID_TOLERANCE = 1e-6
#: Largest magnitude of a coordinate in a description (metres, radians, multipliers).
MAX_ABS_COORDINATE = 1e6
#: Largest magnitude of a joint value (radians or metres): far beyond any joint, small
#: enough that no FK product or Jacobian overflows to inf.
MAX_ABS_JOINT_VALUE = 1e6
#: Below this norm an axis is treated as zero (and refused by the parsers).
AXIS_EPS = 1e-12
#: Below this |det E(phi)| (Euler angles: |cos pitch| or |sin theta|; rotation vectors: pi - theta;
#: quaternions: qw) a task representation counts as singular and its analytic Jacobian is refused.
REPRESENTATION_SINGULARITY_TOLERANCE = 1e-9
#: How far the norm of a floating joint's quaternion, or of a planar joint's (cos, sin), may be
#: from 1 in given joint values (they are then scaled to exactly 1; beyond it they are refused
#: unless the request asks to normalize).
UNIT_NORM_TOLERANCE = 1e-6
#: Default IK tolerances: metres, and radians of the rotation between answer and target.
DEFAULT_POSITION_TOLERANCE = 1e-6
DEFAULT_ROTATION_TOLERANCE = 1e-6
#: IK tolerances below this are refused: no FK is that exact.
MIN_TOLERANCE = 1e-12
#: The smallest damping λ of a damped least-squares IK step (added to ½|e|²): keeps steps
#: bounded at singular configurations.
DAMPING = 1e-9
#: An IK attempt goes on until its errors are this fraction of the tolerances (one more cheap
#: step near convergence), so that answers are not on the edge of their tolerance.
POLISH = 1e-3
