"""A Gaussian prior on the joint parameters: maximum a posteriori estimation.

A few dozen measurements determine the complete set of a 7-joint arm's parameter combinations
only weakly: the fit that explains them best (least squares on the identifiable combinations)
follows their noise in its weakest directions -- a wrist joint's origin turned by a tenth of a
radian -- and predicts other configurations worse than a smaller model would. A robot is built
within tolerances: each joint origin within about a centimetre and a degree of its drawing, each
zero within about a degree. :class:`Prior` says so; the fit then minimises

    sum |residual|^2 / s^2  +  sum_joint parameters (x - x_nominal)^2 / sigma^2

(``s`` the measurement noise, by default the spread of the plain fit's residuals; the device frame
and the tool have no prior: they are unknown, not toleranced). Every joint parameter is fitted; a
combination the data determine is hardly moved by the prior, one they do not stays near nominal.
FIGAROH offers the same estimate (``estimation.method: map``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import CalibrationError


@dataclass(frozen=True)
class Prior:
    """Standard deviations of the joint parameters about nominal (the option of MAP estimation).

    Attributes:
        length: of a joint origin's translation, metres.
        angle: of a joint origin's rotation and of a zero offset, radians (a prismatic joint's
            zero offset is a length).
        compliance: of a joint compliance (:class:`~.compliance.Compliance`), rad/(N m) (m/N prismatic).
        noise: the measurement noise, metres per component; None: the spread of the plain fit's residuals.
    """

    length: float = 0.01
    angle: float = 0.02
    compliance: float = 0.005
    noise: float | None = None

    def __post_init__(self):
        for name in ("length", "angle", "compliance") + (("noise",) if self.noise is not None else ()):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not np.isfinite(v) or v <= 0:
                raise CalibrationError(f"prior: {name} must be a positive number, got {v!r}", field="prior")

    def weights(self, em) -> np.ndarray:
        """``1 / sigma`` (p,) per parameter of the error model ``em`` (0 for the base and the tool)."""
        out = np.zeros(len(em.parameters))
        for i, p in enumerate(em.parameters):
            if p.group in ("base", "tool"):
                continue
            if p.component == "compliance":
                out[i] = 1.0 / self.compliance
            else:
                out[i] = 1.0 / (self.angle if p.angular else self.length)
        return out
