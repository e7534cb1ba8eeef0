"""Kinematic calibration: the robot as it was built, from measurements of a marker or tool.

- :mod:`.errors_model` -- the nominal chain perturbed by small parameters (joint origins, zero
  offsets, the device frame, the tool), with its analytic Jacobian;
- :mod:`.identification` -- which parameter combinations the data determine, and why the rest not;
- :mod:`.estimation` -- :func:`calibrate`: registration, Levenberg-Marquardt, robust loss, statistics;
- :mod:`.compliance` -- :class:`Compliance`: joint compliance under gravity (the non-geometric term);
- :mod:`.prior` -- :class:`Prior`: tolerances on the joint parameters (maximum a posteriori);
- :mod:`.poses` -- :func:`select_poses`: where to measure (D-optimal);
- :mod:`.urdf_out` -- the calibrated URDF; :mod:`.synthetic` -- planted truth for tests and benchmarks.

This package is the only one that imports scipy (the ``calibration`` extra).
"""

from ...errors import MissingExtraError

try:
    import scipy  # noqa: F401
except ImportError as exc:  # the `calibration` extra
    raise MissingExtraError.of("calibration", "kinematic calibration", "scipy") from exc

from .compliance import Compliance
from .estimation import Calibration, FitOptions, calibrate
from .poses import PoseChoice, select_poses
from .prior import Prior

__all__ = ["Calibration", "Compliance", "FitOptions", "PoseChoice", "Prior", "calibrate", "select_poses"]
