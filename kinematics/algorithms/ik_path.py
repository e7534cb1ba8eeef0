"""Cartesian paths: a link moved along straight lines and rotation geodesics, never jumping branches.

:func:`interpolate` cuts the segments between waypoints (N, 4, 4) into targets no further apart
than ``step_position`` (metres) and ``step_rotation`` (radians): positions on the straight segment,
rotations on the geodesic ``R_a exp(s log(R_aᵀ R_b))``.

:func:`cartesian_path` solves them in order by **continuation**: each target takes the solution
of the full set (:func:`~kinematics.algorithms.ik_all.all_solutions`, limits respected, ``2πk``
copies included) nearest the previous row; a chain without a closed form takes damped Newton steps
from the previous row. The path stops at the first target where that is impossible, and says why:
``unreachable`` (no solution, limits or not), ``limits`` (solutions exist, none inside the limits),
``joint_jump`` (the nearest solution is more than ``max_joint_step`` away in some joint: the branch
ends there, e.g. at a singularity, and any continuation would flip the arm); with a
``collision_free`` filter, ``collision`` (the continuation's row there is in self-collision: the
arm would run into itself; the rows before it are free). The continuation never depends on the
filter, so the rows before a stop are those of the same path without it.

The answer's ``fraction`` is the share of the path's length achieved (positions; rotation angles
for a path that only turns).

Ten centimetres along x at 2 cm steps are five steps, six targets:

>>> a, b = np.eye(4), np.eye(4)
>>> b[0, 3] = 0.1
>>> T, length = interpolate(np.array([a, b]), 0.02, 0.05)
>>> T[:, 0, 3].round(3).tolist(), float(length[-1])
([0.0, 0.02, 0.04, 0.06, 0.08, 0.1], 0.1)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..engine.poe import compile_model
from ..errors import KinematicsError
from ..model.robot import RobotModel
from ..spatial.lie import so3_log
from ..spatial.transforms import inverse_transform
from ..tolerances import DEFAULT_POSITION_TOLERANCE, DEFAULT_ROTATION_TOLERANCE, LIMIT_TOLERANCE
from .ik import pose_errors
from .ik_all import all_solutions, newton
from .ik_families import detect, reduce_chain

DEFAULT_STEP_POSITION, DEFAULT_STEP_ROTATION = 0.01, 0.05
DEFAULT_MAX_JOINT_STEP = 0.3
#: at most this many interpolated targets in one path
MAX_TARGETS = 100_000


def _rot(w: np.ndarray) -> np.ndarray:
    """exp of rotation vectors (..., 3) -> (..., 3, 3)."""
    th = np.linalg.norm(w, axis=-1)[..., None, None]
    k = np.where(th[..., 0] > 1e-300, w / np.maximum(th[..., 0], 1e-300), 0.0)
    K = np.zeros(w.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -k[..., 2], k[..., 1], -k[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = k[..., 2], -k[..., 1], k[..., 0]
    return np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * (K @ K)


def interpolate(waypoints: np.ndarray, step_position: float, step_rotation: float) -> tuple[np.ndarray, np.ndarray]:
    """Targets (M, 4, 4) along the waypoints and their arc length (M,) from the start (metres; radians
    for paths without translation)."""
    W = np.asarray(waypoints, dtype=float)
    if W.shape[0] < 2:
        raise KinematicsError("waypoints: give two or more poses")
    if not (step_position > 0 and step_rotation > 0):
        raise KinematicsError("step: position and rotation must be positive")
    out = [W[0]]
    lengths = [0.0]
    use_rotation = all(np.linalg.norm(W[i + 1, :3, 3] - W[i, :3, 3]) == 0 for i in range(len(W) - 1))
    total = 0.0
    for a, b in zip(W[:-1], W[1:]):
        dp = b[:3, 3] - a[:3, 3]
        w = so3_log(a[:3, :3].T @ b[:3, :3])
        # counted in floats first: a tiny step gives an infinite count, which is refused, not converted
        with np.errstate(over="ignore"):
            steps = max(1.0, np.ceil(np.linalg.norm(dp) / step_position - 1e-9),
                        np.ceil(np.linalg.norm(w) / step_rotation - 1e-9))
        if not len(out) + steps <= MAX_TARGETS:
            raise KinematicsError(f"step: the path would have more than {MAX_TARGETS} targets; take larger steps")
        n = int(steps)
        s = np.arange(1, n + 1) / n
        T = np.zeros((n, 4, 4))
        T[:, :3, 3] = a[:3, 3] + s[:, None] * dp
        T[:, :3, :3] = a[:3, :3] @ _rot(s[:, None] * w)
        T[:, 3, 3] = 1.0
        seg = np.linalg.norm(w) if use_rotation else np.linalg.norm(dp)
        out.extend(T)
        lengths.extend(total + s * seg)
        total += seg
    return np.array(out), np.array(lengths)


@dataclass(frozen=True, eq=False)
class PathAnswer:
    """q (K, dof) the achieved rows (K <= M), targets (M, 4, 4) root frame, position_error and
    rotation_error (K,), fraction, complete, stopped (None or {index, reason}), max_joint_step."""

    q: np.ndarray
    targets: np.ndarray
    position_error: np.ndarray
    rotation_error: np.ndarray
    fraction: float
    complete: bool
    stopped: dict | None
    max_joint_step: float
    family: str


def cartesian_path(model: RobotModel, link: str, waypoints: np.ndarray, seed: np.ndarray | None = None, *,
                   base: np.ndarray | None = None, tool: np.ndarray | None = None, locked: dict | None = None,
                   step_position: float = DEFAULT_STEP_POSITION, step_rotation: float = DEFAULT_STEP_ROTATION,
                   max_joint_step: float = DEFAULT_MAX_JOINT_STEP,
                   position_tolerance: float = DEFAULT_POSITION_TOLERANCE,
                   rotation_tolerance: float = DEFAULT_ROTATION_TOLERANCE,
                   collision_free=None) -> PathAnswer:
    """The path of ``link`` (or ``tool`` on it) through ``waypoints`` (N, 4, 4, world frame; ``base``
    ``T_world_root``) from ``seed`` (dof,; default: the solution of the first target nearest the
    middle of the limits). ``collision_free``: None, or ``free(Q)`` (R, dof) -> (R,) bool; the path
    stops at its first row that is not free (reason ``collision``). See the module text."""
    targets, length = path_targets(waypoints, base, step_position, step_rotation, max_joint_step)
    chain = reduce_chain(model, link, locked, tool)
    fam = detect(chain)
    poe = compile_model(model)
    tol = dict(position_tolerance=position_tolerance, rotation_tolerance=rotation_tolerance)
    closed = fam.closed_form
    sets = all_solutions(model, link, targets, tool=tool, locked=locked, limits="respect", **tol) if closed else None
    from .ik import middle_of_limits

    prev = np.array(middle_of_limits(model) if seed is None else seed, dtype=float)
    for name, v in chain.locked.items():
        prev[model.q_index[name]] = v
    cols = chain.columns
    rows: list[np.ndarray] = []
    stopped = None
    others = np.setdiff1d(np.arange(model.dof), cols)
    for i in range(len(targets)):
        best, jump, reason = None, np.inf, "unreachable"
        if closed:
            cands = sets.q[i, :sets.count[i]]
            if len(cands):
                d = np.abs(cands[:, cols] - prev[cols]).max(axis=1)
                k = int(np.argmin(d))
                best, jump = cands[k].copy(), float(d[k])
                best[others] = prev[others]
        if best is None or jump > max_joint_step:
            # continuation from the previous row: the branch itself (through a singularity, where the
            # closed form lists a representative of a continuum, and for chains with no closed form)
            q = newton(poe, link, prev[None], targets[i:i + 1], cols, 40, tool, damped=True)[0]
            q = newton(poe, link, q[None], targets[i:i + 1], cols, 4, tool)[0]
            p, r = pose_errors(poe.fk(q[None], [link], tool=tool)[:, 0], targets[i:i + 1])
            if p[0] <= position_tolerance and r[0] <= rotation_tolerance:
                inside = np.all((q >= model.lower_limits - LIMIT_TOLERANCE) & (q <= model.upper_limits + LIMIT_TOLERANCE))
                step_q = float(np.abs(q[cols] - prev[cols]).max(initial=0.0))
                if inside and step_q < jump:
                    best, jump = q, step_q
                elif not inside and best is None:
                    reason = "limits"
        if best is None:
            if closed:
                reason = _why_none(model, link, targets[i], tool, locked, tol)
            stopped = {"index": i, "reason": reason}
            break
        if i > 0 and jump > max_joint_step:
            stopped = {"index": i, "reason": "joint_jump"}
            break
        rows.append(best)
        prev = best
    return path_answer(poe, link, tool, np.array(rows).reshape(len(rows), model.dof), targets, length, stopped,
                       collision_free, fam.name)


def path_targets(waypoints: np.ndarray, base: np.ndarray | None, step_position: float, step_rotation: float,
                 max_joint_step: float) -> tuple[np.ndarray, np.ndarray]:
    """The interpolated targets (M, 4, 4) in the root frame (``base`` ``T_world_root``) of ``waypoints``
    (world frame) and their arc length (M,), ``max_joint_step`` checked."""
    if not max_joint_step > 0:
        raise KinematicsError("max_joint_step: must be positive")
    W = np.asarray(waypoints, dtype=float).reshape(-1, 4, 4)
    if base is not None:
        W = np.matmul(inverse_transform(base), W)
    return interpolate(W, step_position, step_rotation)


def path_answer(poe, link: str, tool, Q: np.ndarray, targets: np.ndarray, length: np.ndarray, stopped: dict | None,
                collision_free, family: str) -> PathAnswer:
    """The :class:`PathAnswer` of the continuation's rows ``Q`` (K, dof) and its stop (None: complete):
    with a ``collision_free`` filter the rows end at the first one in self-collision."""
    if collision_free is not None and len(Q):
        # the rows in order: the first one in self-collision ends the path there
        free = np.asarray(collision_free(Q), dtype=bool)
        if not free.all():
            first = int(np.argmin(free))
            Q = Q[:first]
            stopped = {"index": first, "reason": "collision"}
    if len(Q):
        p, r = pose_errors(poe.fk(Q, [link], tool=tool)[:, 0], targets[:len(Q)])
    else:
        p = r = np.zeros(0)
    total = float(length[-1])
    achieved = float(length[len(Q) - 1]) if len(Q) else 0.0
    fraction = 1.0 if stopped is None else (achieved / total if total > 0 else 0.0)
    steps = np.abs(np.diff(Q, axis=0)).max(initial=0.0) if len(Q) > 1 else 0.0
    return PathAnswer(Q, targets, p, r, fraction, stopped is None, stopped, float(steps), family)


def _why_none(model, link, target, tool, locked, tol) -> str:
    """``limits`` when the target has solutions outside the limits only, else ``unreachable``."""
    ignoring = all_solutions(model, link, target[None], tool=tool, locked=locked, limits="ignore", **tol)
    return "limits" if ignoring.count[0] > 0 else "unreachable"
