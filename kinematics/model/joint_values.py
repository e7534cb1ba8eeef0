"""Joint vectors as users give them -> validated ``(N, nq)`` arrays, and limit checks.

q may be a vector in ``joint_names`` order, a ``{joint_name: value}`` map, or a list of
either (a batch). Errors name what is wrong: the expected and given lengths, the missing
or unknown joint names, the configuration and joint holding a NaN. This module is the one
reader of joint values: every use case hands q down to :func:`read_joint_values` (or
:func:`as_batch`) and gets the ``(N, nq)`` array the engine computes with.

A floating joint takes 7 entries ``x, y, z, qx, qy, qz, qw`` and a planar joint 4 entries
``x, y, cos θ, sin θ`` (Pinocchio's layout, :attr:`RobotModel.layout`); in a name map their
value is a list of 7 (4) numbers, and a floating joint's may also be a pose object
(``{"position", "quaternion"}``, ``{"xyz", "rpy"}`` or a 4x4 matrix, read by
:func:`floating_joint_values`). The quaternion and the ``(cos, sin)`` pair must be of unit
norm within ``UNIT_NORM_TOLERANCE`` (else :class:`~kinematics.errors.ConfigurationNormError`
naming the joint), or are scaled to it when ``normalize`` is asked; accepted values are always
scaled to exactly unit norm, so every pose computed from them is rigid.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..errors import ConfigurationNormError, JointValueError, LimitError, PoseError, did_you_mean
from ..spatial.pose_data import read_pose, read_vector
from ..spatial.rotations import matrix_to_quaternion
from ..tolerances import LIMIT_TOLERANCE, MAX_ABS_JOINT_VALUE, UNIT_NORM_TOLERANCE
from .robot import RobotModel


def floating_joint_values(values: Mapping, floating: Sequence[str], where: str = "") -> dict:
    """A ``{joint: value}`` map whose floating joints (names in ``floating``) may be given as a pose:
    ``{"position", "quaternion": {w, x, y, z}}`` (taken as given: its norm is checked, naming the
    joint, with the rest of q), ``{"xyz", "rpy"}`` or a 4x4 matrix (rigid) -> the same map with
    those joints as their 7 values ``x, y, z, qx, qy, qz, qw`` (Pinocchio's layout). Other
    values are left as they are.

    >>> floating_joint_values({"root": {"xyz": [1, 2, 3], "rpy": [0, 0, 0]}, "elbow": 0.5}, ["root"])
    {'root': [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0], 'elbow': 0.5}
    """
    out = dict(values)
    for name in floating:
        v = values.get(name)
        is_matrix = (isinstance(v, Sequence) and not isinstance(v, (str, bytes)) and len(v) == 4
                     and all(isinstance(r, Sequence) and not isinstance(r, (str, bytes)) for r in v))
        if not (isinstance(v, Mapping) or is_matrix):
            continue
        at = f"{where}joint {name!r}"
        if isinstance(v, Mapping) and set(v) == {"position", "quaternion"}:
            quat = v["quaternion"]
            if not isinstance(quat, Mapping) or set(quat) != {"w", "x", "y", "z"}:
                raise JointValueError(f"{at}: quaternion: expected {{\"w\", \"x\", \"y\", \"z\"}}, got {quat!r}")
            p = read_vector(v["position"], 3, f"{at}: position", PoseError)
            out[name] = [*map(float, p), *(_quaternion_entry(quat[k], at) for k in ("x", "y", "z", "w"))]
            continue
        try:
            T = read_pose(v, at, PoseError)
        except PoseError as exc:
            raise JointValueError(str(exc)) from None
        w, x, y, z = matrix_to_quaternion(T[:3, :3])
        out[name] = [*map(float, T[:3, 3]), float(x), float(y), float(z), float(w)]
    return out


def _quaternion_entry(v, where: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise JointValueError(f"{where}: quaternion entry {v!r} is not a number")
    return float(v)


def _pose_values(model: RobotModel, q):
    """q with every floating joint given as a pose object in a name map replaced by its 7 values
    (other forms unchanged)."""
    if not model.multi_dof:
        return q
    floating = [s.name for s in model.layout if s.type == "floating"]
    if not floating:
        return q
    if isinstance(q, Mapping):
        return floating_joint_values(q, floating)
    if isinstance(q, list) and q and any(isinstance(x, Mapping) for x in q):
        return [floating_joint_values(x, floating, f"configuration {i}: ") if isinstance(x, Mapping) else x
                for i, x in enumerate(q)]
    return q


def read_joint_values(model: RobotModel, q, normalize: bool = False) -> tuple[np.ndarray, bool]:
    """``(Q (N, nq), is_batch)`` of joint values in any form a request gives them: :func:`as_batch`,
    with a list of equal-length number lists read as one array at once (the common batch, so a
    large batch is not validated number by number; ragged lists and name maps go through
    :func:`as_batch`, which names what is wrong). An empty batch is refused.

    >>> from kinematics.io import default_catalogue
    >>> Q, is_batch = read_joint_values(default_catalogue().get("ur5"), [[0.0] * 6] * 3)
    >>> Q.shape, is_batch
    ((3, 6), True)
    """
    if isinstance(q, list) and q and isinstance(q[0], list):
        try:
            arr = np.array(q, dtype=float)
        except (TypeError, ValueError):  # ragged or not numbers: let as_batch name the configuration
            arr = None
        if arr is not None and arr.ndim == 2:
            q = arr
    Q, is_batch = as_batch(model, q, normalize)
    if Q.shape[0] == 0:
        raise JointValueError("q has no configuration")
    return Q, is_batch


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
    if not model.multi_dof:
        return np.array([_scalar(values[n], where, n) for n in model.joint_names], dtype=float)
    out = np.empty(model.nq)
    for s in model.layout:
        v = values[s.name]
        if s.nq == 1:
            out[s.q_start] = _scalar(v, where, s.name)
            continue
        form = "x, y, z, qx, qy, qz, qw" if s.type == "floating" else "x, y, cos(theta), sin(theta)"
        if not isinstance(v, Sequence) or isinstance(v, (str, bytes)) or len(v) != s.nq:
            raise JointValueError(f"{where}joint {s.name!r} is a {s.type} joint: give {s.nq} numbers ({form})"
                                  + (" or a pose" if s.type == "floating" else "") + f", got {v!r}")
        out[s.q_slice] = [_scalar(x, where, s.name) for x in v]
    return out


def _scalar(v, where: str, name: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise JointValueError(f"{where}joint {name!r}: value {v!r} is not a number")
    try:
        return float(v)
    except OverflowError:  # an int beyond any float
        raise JointValueError(f"{where}joint {name!r}: an integer of {int(v).bit_length()} bits is beyond "
                              f"+-{MAX_ABS_JOINT_VALUE:g}") from None


def _plain_vector(model: RobotModel, q) -> np.ndarray | None:
    """``q`` as a (1, nq) array when it is a list of ``nq`` Python floats and ints (what a JSON body
    gives), else None (then :func:`_from_seq` and the others read it and name what is wrong): the same
    values as :func:`_from_seq` gives, a few microseconds sooner."""
    if q.__class__ is not list or len(q) != model.nq:
        return None
    for x in q:
        if x.__class__ is not float and x.__class__ is not int:
            return None
    try:
        return np.array(q, dtype=float)[None, :]
    except OverflowError:  # an int too large for a float: _from_seq says which joint
        return None


def _from_seq(model: RobotModel, values: Sequence, where: str) -> np.ndarray:
    if len(values) != model.nq:
        order = list(model.joint_names) if not model.multi_dof else list(model.q_labels)
        raise JointValueError(
            f"{where}expected {model.nq} joint values (in the order {order}), got {len(values)}"
        )
    labels = model.joint_names if not model.multi_dof else model.q_labels
    return np.array([_scalar(v, where, labels[i]) for i, v in enumerate(values)], dtype=float)


def unit_parts(model: RobotModel, Q: np.ndarray, normalize: bool = False, batch: bool = True) -> np.ndarray:
    """Check (and scale to exactly 1) the norm of every floating joint's quaternion and planar
    joint's ``(cos, sin)`` in Q (N, nq), in place; returns Q. Off the unit norm by more than
    ``UNIT_NORM_TOLERANCE`` raises :class:`ConfigurationNormError` naming the configuration and
    joint, unless ``normalize`` (then only a norm below ``UNIT_NORM_TOLERANCE`` is refused)."""
    for s in model.layout:
        if s.type == "floating":
            cols, what = slice(s.q_start + 3, s.q_start + 7), "quaternion (qx, qy, qz, qw)"
        elif s.type == "planar":
            cols, what = slice(s.q_start + 2, s.q_start + 4), "(cos(theta), sin(theta))"
        else:
            continue
        norm = np.linalg.norm(Q[:, cols], axis=1)
        bad = (norm < UNIT_NORM_TOLERANCE) if normalize else (np.abs(norm - 1.0) > UNIT_NORM_TOLERANCE)
        if bad.any():
            n = int(np.flatnonzero(bad)[0])
            where = f"configuration {n}, " if batch else ""
            hint = ("it cannot be scaled to unit norm" if normalize else
                    f"it must be of unit norm within {UNIT_NORM_TOLERANCE:g} (send normalize: true to scale it)")
            raise ConfigurationNormError(f"{where}joint {s.name!r} ({s.type}): the {what} has norm {norm[n]:.9g}; "
                                         + hint, joint=s.name)
        Q[:, cols] /= norm[:, None]
    return Q


def as_batch(model: RobotModel, q, normalize: bool = False) -> tuple[np.ndarray, bool]:
    """``(Q, is_batch)``: Q is a finite float64 array of shape (N, nq) (nq = dof for a model of
    one-dof joints).

    A flat vector or a name map is one configuration (``is_batch`` False); a list of them,
    or a 2-D array, is a batch. Quaternions and planar ``(cos, sin)`` pairs are checked and
    scaled to unit norm (:func:`unit_parts`; ``normalize``: scale any non-zero one). A floating
    joint's value in a name map may be a pose object (:func:`floating_joint_values`).
    """
    q = _pose_values(model, q)
    Q = _plain_vector(model, q)
    if Q is not None:  # the most common form, read without the checks below that name what is wrong
        batch = False
    elif isinstance(q, np.ndarray):
        if q.dtype.kind not in "fiu":
            raise JointValueError(f"joint values must be numbers, got an array of dtype {q.dtype}")
        if q.ndim == 1:
            Q, batch = q[None, :].astype(float), False
        elif q.ndim == 2:
            Q, batch = q.astype(float), True
        else:
            raise JointValueError(f"joint values must be a vector or an (N, dof) array, got shape {q.shape}")
        if Q.shape[1] != model.nq:
            raise JointValueError(f"expected {model.nq} joint values per configuration, got {Q.shape[1]}")
    elif isinstance(q, Mapping):
        Q, batch = _from_map(model, q, "")[None, :], False
    elif isinstance(q, Sequence) and not isinstance(q, (str, bytes)):
        if len(q) > 0 and all(isinstance(x, (Mapping, Sequence)) and not isinstance(x, (str, bytes)) for x in q):
            rows = []
            for i, x in enumerate(q):
                where = f"configuration {i}: "
                rows.append(_from_map(model, x, where) if isinstance(x, Mapping) else _from_seq(model, x, where))
            Q, batch = np.array(rows, dtype=float).reshape(len(rows), model.nq), True
        elif len(q) > 0 and any(isinstance(x, (Mapping, Sequence)) and not isinstance(x, (str, bytes)) for x in q):
            raise JointValueError("q mixes numbers and lists: give one vector, or a list of vectors")
        else:
            Q, batch = _from_seq(model, q, "")[None, :], False
    else:
        raise JointValueError(f"q must be a list of numbers, a name map or a list of those, got {type(q).__name__}")
    labels = model.joint_names if not model.multi_dof else model.q_labels
    bad = ~np.isfinite(Q)
    if bad.any():
        n, j = map(int, np.argwhere(bad)[0])
        where = f"configuration {n}, " if batch else ""
        raise JointValueError(f"{where}joint {labels[j]!r}: value {Q[n, j]} is not finite")
    huge = np.abs(Q) > MAX_ABS_JOINT_VALUE
    if huge.any():
        n, j = map(int, np.argwhere(huge)[0])
        where = f"configuration {n}, " if batch else ""
        raise JointValueError(
            f"{where}joint {labels[j]!r}: value {Q[n, j]:g} is beyond +-{MAX_ABS_JOINT_VALUE:g}"
        )
    if model.multi_dof:
        if not Q.flags.writeable or np.shares_memory(Q, q if isinstance(q, np.ndarray) else Q[:0]):
            Q = Q.copy()
        unit_parts(model, Q, normalize, batch)
    return Q, batch


def limit_violations(model: RobotModel, Q: np.ndarray) -> np.ndarray:
    """``(N, nq)`` boolean mask: True where ``Q[n, j]`` lies outside its joint's limits (Q in q order)."""
    Q = np.asarray(Q, dtype=float)
    return (Q < model.lower_limits - LIMIT_TOLERANCE) | (Q > model.upper_limits + LIMIT_TOLERANCE)


def out_of_limits(model: RobotModel, Q: np.ndarray) -> list[list[str]]:
    """Per configuration, the names of the joints whose value lies outside its limits.

    Vectorised: names are only looked up for the configurations that have a violation
    (a batch within its limits costs one comparison and N empty lists).
    """
    bad = limit_violations(model, Q)
    result: list[list[str]] = [[] for _ in range(bad.shape[0])]
    names = model.joint_names if not model.multi_dof else _joint_of_entry(model)
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
        name = model.joint_names[j] if not model.multi_dof else _joint_of_entry(model)[j]
        raise LimitError(
            f"configuration {n}: joint {name!r} value {Q[n, j]} is outside its limits "
            f"[{model.lower_limits[j]}, {model.upper_limits[j]}]"
            + (f" (and {len(cols) - 1} more)" if len(cols) > 1 else "")
        )


def _joint_of_entry(model: RobotModel) -> list[str]:
    """The joint name of each entry of q."""
    return [s.name for s in model.layout for _ in range(s.nq)]


def as_velocity_batch(model: RobotModel, qdot) -> tuple[np.ndarray, bool]:
    """``(Qd, is_batch)``: joint velocities as a finite float64 array (N, nv) -- a vector in the
    velocity layout (:attr:`RobotModel.layout` v slices), a ``{joint: value}`` map (a floating joint's
    value 6 numbers, its twist ``vx, vy, vz, wx, wy, wz`` in its own frame; a planar joint's 3,
    ``vx, vy, wz``), or a list of either (a batch)."""
    labels = model.v_labels

    def from_map(values: Mapping, where: str) -> np.ndarray:
        unknown = [k for k in values if k not in model.slot]
        if unknown:
            raise JointValueError(f"{where}unknown joint name(s): {', '.join(map(str, unknown))}"
                                  + did_you_mean(str(unknown[0]), model.joint_names, "joint names"))
        missing = [n for n in model.joint_names if n not in values]
        if missing:
            raise JointValueError(f"{where}missing value(s) for joint(s): {', '.join(missing)}")
        out = np.empty(model.nv)
        for s in model.layout:
            v = values[s.name]
            if s.nv == 1:
                out[s.v_start] = _scalar(v, where, s.name)
            elif not isinstance(v, Sequence) or isinstance(v, (str, bytes)) or len(v) != s.nv:
                raise JointValueError(f"{where}joint {s.name!r} is a {s.type} joint: give {s.nv} velocities, got {v!r}")
            else:
                out[s.v_slice] = [_scalar(x, where, s.name) for x in v]
        return out

    def from_seq(values: Sequence, where: str) -> np.ndarray:
        if len(values) != model.nv:
            raise JointValueError(f"{where}expected {model.nv} joint velocities (in the order {list(labels)}), "
                                  f"got {len(values)}")
        return np.array([_scalar(v, where, labels[i]) for i, v in enumerate(values)], dtype=float)

    if isinstance(qdot, np.ndarray):
        if qdot.dtype.kind not in "fiu" or qdot.ndim not in (1, 2):
            raise JointValueError(f"joint velocities must be a vector or an (N, {model.nv}) array of numbers")
        Qd, batch = np.atleast_2d(qdot).astype(float), qdot.ndim == 2
        if Qd.shape[1] != model.nv:
            raise JointValueError(f"expected {model.nv} joint velocities per configuration, got {Qd.shape[1]}")
    elif isinstance(qdot, Mapping):
        Qd, batch = from_map(qdot, "")[None, :], False
    elif isinstance(qdot, Sequence) and not isinstance(qdot, (str, bytes)):
        if qdot and all(isinstance(x, Mapping) or (isinstance(x, Sequence) and not isinstance(x, (str, bytes)))
                        for x in qdot):
            rows = [from_map(x, f"configuration {i}: ") if isinstance(x, Mapping) else from_seq(x, f"configuration {i}: ")
                    for i, x in enumerate(qdot)]
            Qd, batch = np.array(rows, dtype=float).reshape(len(rows), model.nv), True
        else:
            Qd, batch = from_seq(qdot, "")[None, :], False
    else:
        raise JointValueError(f"joint velocities must be a list of numbers, a name map or a list of those, "
                              f"got {type(qdot).__name__}")
    bad = ~np.isfinite(Qd) | (np.abs(Qd) > MAX_ABS_JOINT_VALUE)
    if bad.any():
        n, j = map(int, np.argwhere(bad)[0])
        where = f"configuration {n}, " if batch else ""
        raise JointValueError(f"{where}joint {labels[j]!r}: velocity {Qd[n, j]:g} is not finite or beyond "
                              f"+-{MAX_ABS_JOINT_VALUE:g}")
    return Qd, batch
