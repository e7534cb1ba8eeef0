"""Calibration measurements as CSV: one row per measurement, joint columns by name, then the measure.

The header names every joint of q (in any order) and then either ``x,y,z`` (a marker's
position, metres, in the measuring device's frame) or ``x,y,z,qw,qx,qy,qz`` (a tool's pose:
position and unit quaternion). Blank lines and lines starting with ``#`` are skipped. The text
is parsed as data only; no file a cell names is ever opened.

>>> text = "a,b,x,y,z\\n0.1,0.2,1,2,3\\n0.3,0.4,4,5,6\\n"
>>> m = parse_measurements_csv(text, ("a", "b"))
>>> m.q.tolist(), m.positions.tolist(), m.poses is None
([[0.1, 0.2], [0.3, 0.4]], [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]], True)
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..errors import CalibrationError
from ..spatial.rotations import quaternion_to_matrix
from ..spatial.transforms import make_transform

POSITION_COLUMNS = ("x", "y", "z")
POSE_COLUMNS = ("x", "y", "z", "qw", "qx", "qy", "qz")


@dataclass(frozen=True)
class Measurements:
    """``q`` (N, dof) in the model's joint order; ``positions`` (N, 3) or ``poses`` (N, 4, 4)."""

    q: np.ndarray
    positions: np.ndarray | None
    poses: np.ndarray | None


def parse_measurements_csv(text: str | bytes, joint_names: Sequence[str], max_rows: int = 1_000_000) -> Measurements:
    """The measurements of a CSV text (see the module); errors name the column or the row."""
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8-sig")
        except UnicodeDecodeError:
            raise CalibrationError("the measurements CSV is not UTF-8 text") from None
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise CalibrationError("the measurements CSV is empty")
    rows = list(csv.reader(io.StringIO("\n".join(lines))))
    header = [h.strip() for h in rows[0]]
    if len(set(header)) != len(header):
        dup = sorted({h for h in header if header.count(h) > 1})
        raise CalibrationError(f"the CSV header repeats the column(s) {', '.join(dup)}")
    missing = [j for j in joint_names if j not in header]
    if missing:
        raise CalibrationError(f"the CSV header lacks the joint column(s) {', '.join(missing)} "
                               f"(it must name every joint: {', '.join(joint_names)})")
    rest = [h for h in header if h not in joint_names]
    if tuple(rest) == POSITION_COLUMNS:
        measure = POSITION_COLUMNS
    elif tuple(rest) == POSE_COLUMNS:
        measure = POSE_COLUMNS
    else:
        raise CalibrationError("after the joint columns the CSV must have x,y,z or x,y,z,qw,qx,qy,qz; "
                               f"got {','.join(rest)}")
    if len(rows) - 1 > max_rows:
        raise CalibrationError(f"the CSV has {len(rows) - 1} rows, more than {max_rows}")
    data = np.empty((len(rows) - 1, len(header)))
    for r, row in enumerate(rows[1:]):
        if len(row) != len(header):
            raise CalibrationError(f"CSV row {r + 1}: {len(row)} values for {len(header)} columns")
        try:
            data[r] = [float(v) for v in row]
        except ValueError:
            raise CalibrationError(f"CSV row {r + 1}: a value that is not a number") from None
    if not data.shape[0]:
        raise CalibrationError("the measurements CSV has a header and no row")
    col = {h: i for i, h in enumerate(header)}
    Q = data[:, [col[j] for j in joint_names]]
    P = data[:, [col[c] for c in POSITION_COLUMNS]]
    if measure == POSITION_COLUMNS:
        return Measurements(Q, P, None)
    quat = data[:, [col[c] for c in ("qw", "qx", "qy", "qz")]]
    norms = np.linalg.norm(quat, axis=1)
    bad = np.flatnonzero(~np.isfinite(norms) | (np.abs(norms - 1.0) > 1e-6))
    if bad.size:
        raise CalibrationError(f"CSV row {int(bad[0]) + 1}: the quaternion qw,qx,qy,qz is not of unit norm")
    poses = np.stack([make_transform(quaternion_to_matrix(*(quat[i] / norms[i])), P[i]) for i in range(len(P))])
    return Measurements(Q, None, poses)
