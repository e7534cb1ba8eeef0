"""Helpers the tests share: ``.npy`` bodies and files, the agreement bound with Pinocchio, and a guard
that fails a test which opens any file."""

from __future__ import annotations

import builtins
import io
import os
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


def refuse_files(monkeypatch) -> None:
    """From now on (until ``monkeypatch`` undoes it) any ``open`` -- ``builtins.open``, ``io.open``,
    ``os.open`` -- fails the test with an ``AssertionError`` naming the file."""
    def refuse(*args, **kwargs):
        raise AssertionError(f"a file was opened: {args[:1]}")

    monkeypatch.setattr(builtins, "open", refuse)
    monkeypatch.setattr(io, "open", refuse)
    monkeypatch.setattr(os, "open", refuse)
