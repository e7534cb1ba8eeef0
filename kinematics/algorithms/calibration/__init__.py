"""Kinematic calibration: the robot as it was built, from measurements of a marker or tool.

- :mod:`.errors_model` -- the nominal chain perturbed by small parameters (joint origins, zero
  offsets, the device frame, the tool), with its analytic Jacobian;
- :mod:`.identification` -- which parameter combinations the data determine, and why the rest not;
- :mod:`.estimation` -- :func:`calibrate`: registration, Levenberg-Marquardt, robust loss, statistics;
- :mod:`.poses` -- :func:`select_poses`: where to measure (D-optimal);
- :mod:`.urdf_out` -- the calibrated URDF; :mod:`.synthetic` -- planted truth for tests and benchmarks.

This package is the only one that imports scipy (the ``calibration`` extra).
"""

from .estimation import Calibration, calibrate
from .poses import PoseChoice, select_poses

__all__ = ["Calibration", "PoseChoice", "calibrate", "select_poses"]
