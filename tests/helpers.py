"""Helpers the tests share: ``.npy`` bodies and files, and the agreement bound with Pinocchio."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from kinematics.tolerances import AGREEMENT_TOLERANCE

#: results agree with Pinocchio to this (absolute, metres / radians / Jacobian entries)
PINOCCHIO_TOL = AGREEMENT_TOLERANCE


def npy_bytes(a) -> bytes:
    """``np.save`` of ``a``: an array as it is (hostile dtypes included, pickled if it must), anything
    else (nested lists) as float64."""
    buf = io.BytesIO()
    np.save(buf, a if isinstance(a, np.ndarray) else np.asarray(a, dtype=np.float64), allow_pickle=True)
    return buf.getvalue()


def write_npy(path: Path, a) -> Path:
    """``a`` saved as an ``.npy`` file at ``path`` (as :func:`npy_bytes`); returns ``path``."""
    path.write_bytes(npy_bytes(a))
    return path
