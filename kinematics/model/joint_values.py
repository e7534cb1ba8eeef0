"""Joint vectors as users give them -> validated ``(N, dof)`` arrays, and limit checks.

q may be a vector in ``joint_names`` order, a ``{joint_name: value}`` map, or a list of
either (a batch). Errors name what is wrong: the expected and given lengths, the missing
or unknown joint names, the configuration and joint holding a NaN.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..errors import JointValueError, LimitError, did_you_mean
from ..tolerances import LIMIT_TOLERANCE, MAX_ABS_JOINT_VALUE
from .robot import RobotModel


def _from_map(model: RobotModel, values: Mapping, where: str) -> np.ndarray:
    unknown = [k for k in values if k not in model.q_index]
    if unknown:
        hint = ""
        mimic = [k for k in unknown if k in model.joint_map and model.joint_map[k].mimic is not None]
        if mimic:
            hint = f" ({', '.join(mimic)} {'is a mimic joint' if len(mimic) == 1 else 'are mimic joints'}, set by the leader)"
        else:
            hint = did_you_mean(unknown[0], model.joint_names, "joint names")
        raise JointValueError(f"{where}unknown joint name(s): {', '.join(map(str, unknown))}{hint}")
    missing = [n for n in model.joint_names if n not in values]
    if missing:
        raise JointValueError(f"{where}missing value(s) for joint(s): {', '.join(missing)}")
    return np.array([_scalar(values[n], where, n) for n in model.joint_names], dtype=float)


def _scalar(v, where: str, name: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise JointValueError(f"{where}joint {name!r}: value {v!r} is not a number")
    return float(v)


def _from_seq(model: RobotModel, values: Sequence, where: str) -> np.ndarray:
    if len(values) != model.dof:
        raise JointValueError(
            f"{where}expected {model.dof} joint values (in the order {list(model.joint_names)}), got {len(values)}"
        )
    return np.array([_scalar(v, where, model.joint_names[i]) for i, v in enumerate(values)], dtype=float)


def as_batch(model: RobotModel, q) -> tuple[np.ndarray, bool]:
    """``(Q, is_batch)``: Q is a finite float64 array of shape (N, dof).

    A flat vector or a name map is one configuration (``is_batch`` False); a list of them,
    or a 2-D array, is a batch.
    """
    if isinstance(q, np.ndarray):
        if q.dtype.kind not in "fiu":
            raise JointValueError(f"joint values must be numbers, got an array of dtype {q.dtype}")
        if q.ndim == 1:
            Q, batch = q[None, :].astype(float), False
        elif q.ndim == 2:
            Q, batch = q.astype(float), True
        else:
            raise JointValueError(f"joint values must be a vector or an (N, dof) array, got shape {q.shape}")
        if Q.shape[1] != model.dof:
            raise JointValueError(f"expected {model.dof} joint values per configuration, got {Q.shape[1]}")
    elif isinstance(q, Mapping):
        Q, batch = _from_map(model, q, "")[None, :], False
    elif isinstance(q, Sequence) and not isinstance(q, (str, bytes)):
        if len(q) > 0 and all(isinstance(x, (Mapping, Sequence)) and not isinstance(x, (str, bytes)) for x in q):
            rows = []
            for i, x in enumerate(q):
                where = f"configuration {i}: "
                rows.append(_from_map(model, x, where) if isinstance(x, Mapping) else _from_seq(model, x, where))
            Q, batch = np.array(rows, dtype=float).reshape(len(rows), model.dof), True
        elif len(q) > 0 and any(isinstance(x, (Mapping, Sequence)) and not isinstance(x, (str, bytes)) for x in q):
            raise JointValueError("q mixes numbers and lists: give one vector, or a list of vectors")
        else:
            Q, batch = _from_seq(model, q, "")[None, :], False
    else:
        raise JointValueError(f"q must be a list of numbers, a name map or a list of those, got {type(q).__name__}")
    bad = ~np.isfinite(Q)
    if bad.any():
        n, j = map(int, np.argwhere(bad)[0])
        where = f"configuration {n}, " if batch else ""
        raise JointValueError(f"{where}joint {model.joint_names[j]!r}: value {Q[n, j]} is not finite")
    huge = np.abs(Q) > MAX_ABS_JOINT_VALUE
    if huge.any():
        n, j = map(int, np.argwhere(huge)[0])
        where = f"configuration {n}, " if batch else ""
        raise JointValueError(
            f"{where}joint {model.joint_names[j]!r}: value {Q[n, j]:g} is beyond +-{MAX_ABS_JOINT_VALUE:g}"
        )
    return Q, batch


def limit_violations(model: RobotModel, Q: np.ndarray) -> np.ndarray:
    """``(N, dof)`` boolean mask: True where ``Q[n, j]`` lies outside joint j's limits (Q in q order)."""
    Q = np.asarray(Q, dtype=float)
    return (Q < model.lower_limits - LIMIT_TOLERANCE) | (Q > model.upper_limits + LIMIT_TOLERANCE)


def out_of_limits(model: RobotModel, Q: np.ndarray) -> list[list[str]]:
    """Per configuration, the names of the joints whose value lies outside its limits.

    Vectorised: names are only looked up for the configurations that have a violation
    (a batch within its limits costs one comparison and N empty lists).
    """
    bad = limit_violations(model, Q)
    result: list[list[str]] = [[] for _ in range(bad.shape[0])]
    names = model.joint_names
    for n in np.flatnonzero(bad.any(axis=1)).tolist():
        result[n] = [names[j] for j in np.flatnonzero(bad[n]).tolist()]
    return result


def require_within_limits(model: RobotModel, Q: np.ndarray) -> None:
    """Raise :class:`LimitError` naming the first configuration and joint outside its limits."""
    bad = limit_violations(model, Q)
    rows = np.flatnonzero(bad.any(axis=1))
    if rows.size:
        n = int(rows[0])
        cols = np.flatnonzero(bad[n])
        j = int(cols[0])
        raise LimitError(
            f"configuration {n}: joint {model.joint_names[j]!r} value {Q[n, j]} is outside its limits "
            f"[{model.lower_limits[j]}, {model.upper_limits[j]}]"
            + (f" (and {len(cols) - 1} more)" if len(cols) > 1 else "")
        )
