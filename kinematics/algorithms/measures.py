"""Conditioning measures of Jacobians: singular values, manipulability, condition number."""

from __future__ import annotations

import numpy as np


#: Singular values below this count as zero when the condition number is computed.
SINGULAR_EPS = 1e-12


def conditioning(J: np.ndarray) -> dict[str, np.ndarray]:
    """Singular values, Yoshikawa manipulability and condition number of Jacobians (..., 6, n).

    manipulability = ``sqrt(det(J J^T))`` = product of the singular values (for n < 6,
    the product of the n singular values, i.e. ``sqrt(det(J^T J))``, so an arm with fewer
    than six joints is not reported as singular everywhere). condition number =
    largest / smallest singular value (``inf`` at a singularity; 1 for n = 0).
    """
    J = np.asarray(J, dtype=float)
    if J.shape[-1] == 0:
        batch = J.shape[:-2]
        return {
            "singular_values": np.zeros(batch + (0,)),
            "manipulability": np.ones(batch),
            "condition_number": np.ones(batch),
        }
    s = np.linalg.svd(J, compute_uv=False)
    smin = s[..., -1]
    with np.errstate(divide="ignore"):
        cond = np.where(smin > SINGULAR_EPS, s[..., 0] / np.where(smin > 0, smin, 1.0), np.inf)
    return {"singular_values": s, "manipulability": np.prod(s, axis=-1), "condition_number": cond}
