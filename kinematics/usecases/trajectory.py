"""Trajectories: a path through joint waypoints, timed under joint velocity, acceleration (and
jerk) limits and a tool's linear speed, sampled at a rate.

The path (``interpolation``): ``"spline"``, the not-a-knot cubic spline through the waypoints
at ``s = 0, 1/(M-1), ..., 1`` (as ``scipy.interpolate.CubicSpline(np.linspace(0, 1, M),
waypoints)``); ``"linear"``, straight segments joined by blends within ``blend`` of each corner
(0: stop at each corner). The timing (:mod:`kinematics.algorithms.trajectory`) is time-optimal
for velocity and acceleration (and tool speed) limits, every limit held at every instant, or,
with ``jerk``, jerk-limited with the acceleration continuous and zero at both ends.

Limits (:class:`TrajectoryLimits`): ``velocity`` defaults to the model's ``<limit velocity>``;
a joint without one (or 0) must be given one. ``acceleration`` has no source in a robot
description and no default: it is required. Each is one number or one per joint.

>>> from kinematics.io import default_catalogue
>>> ur5 = default_catalogue().get("ur5")
>>> answer = trajectory(ur5, [[0.0] * 6, [0.5, -0.5, 0.5, 0.0, 0.0, 0.0]], TrajectoryLimits(acceleration=2.0), rate=50)
>>> answer.q[0].tolist() == [0.0] * 6, bool(abs(answer.qd[-1]).max() < 1e-9), bool(answer.t[-1] == answer.duration)
(True, True, True)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from ..algorithms.trajectory.path import PiecewisePath, linear_path, poly_range, spline_path
from ..algorithms.trajectory.plan import Timing, plan, sample_times
from ..algorithms.trajectory.topp import ToolRate
from ..engine.poe import compile_model
from ..errors import BudgetError, JointValueError, KinematicsError, LimitError
from ..io.poses import tool_offset
from ..model.robot import RobotModel
from ..spatial.reference import Reference
from ..tolerances import LIMIT_TOLERANCE
from .query import Query, prefixed

INTERPOLATIONS = ("spline", "linear")
#: the largest sampling rate, Hz
MAX_RATE = 100_000.0
#: grid intervals of the time-optimal profile over the whole path
DEFAULT_GRID_POINTS = 2000


class TrajectoryError(KinematicsError):
    """A trajectory request that cannot be planned as given (its limits, its path)."""


@dataclass(frozen=True)
class Sampling:
    """The caller's bounds on sampling: the largest ``rate`` (Hz, at most :data:`MAX_RATE`) and the most
    samples of one answer (None: unbounded); over either, :class:`~kinematics.errors.BudgetError`."""

    max_rate: float = MAX_RATE
    max_samples: int | None = None

    def check(self, rate: float, duration: float) -> None:
        if not (np.isfinite(rate) and rate > 0):
            raise TrajectoryError(f"rate: {rate:g} Hz; give a rate > 0 (at most {self.max_rate:g})")
        if rate > min(self.max_rate, MAX_RATE):
            raise BudgetError(f"rate: {rate:g} Hz; the limit (trajectory_max_rate) is {min(self.max_rate, MAX_RATE):g}",
                              budget="trajectory-rate", field="rate", limit=int(min(self.max_rate, MAX_RATE)))
        n = int(np.floor(duration * rate)) + 2
        if self.max_samples is not None and n > self.max_samples:
            count = f"{n}" if n < 10**15 else f"{float(n):.3g}"
            raise BudgetError(f"the trajectory would have {count} samples ({duration:.6g} s at {rate:g} Hz); the limit "
                              f"(trajectory_max_samples) is {self.max_samples}: lower the rate",
                              budget="trajectory-samples", field="rate", limit=self.max_samples)


@dataclass(frozen=True)
class ToolSpeed:
    """The largest linear speed ``max`` (m/s) of ``link``'s origin (or of ``point`` on it), world axes."""

    link: str
    max: float
    point: Sequence[float] | None = None


@dataclass(frozen=True)
class TrajectoryLimits:
    """The limits of a trajectory: ``velocity`` (None: the model's), ``acceleration`` (required),
    ``jerk`` (None: not limited), each a number or one per joint; ``tool_speed``."""

    velocity: Any = None
    acceleration: Any = None
    jerk: Any = None
    tool_speed: ToolSpeed | None = None


@dataclass(frozen=True, eq=False)
class TrajectoryAnswer:
    """``t`` (K,), ``q``, ``qd``, ``qdd`` (K, dof) sampled at ``rate`` from 0 to ``duration``; ``limits``
    the per-joint limits used; ``timing`` evaluates the motion at any time; ``optimal_duration`` the
    time-optimal duration under velocity and acceleration alone (reported beside a jerk-limited one)."""

    model: RobotModel
    joint_names: list[str]
    duration: float
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    method: str
    limits: dict[str, Any]
    path: PiecewisePath
    timing: Timing
    optimal_duration: float | None = None


def per_joint(value: Any, names: Sequence[str], what: str) -> np.ndarray | None:
    """A limit as one positive finite number per joint (None stays None)."""
    if value is None:
        return None
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(len(names), float(arr))
    if arr.shape != (len(names),):
        raise TrajectoryError(f"limits.{what}: give one number or {len(names)} (one per joint: "
                              f"{', '.join(names)}), got {arr.size}")
    bad = ~np.isfinite(arr) | (arr <= 0)
    if bad.any():
        j = int(np.argmax(bad))
        raise TrajectoryError(f"limits.{what}: joint {names[j]!r} has {arr[j]:g}; a limit must be a positive number")
    return arr


def model_velocity(model: RobotModel, names: Sequence[str]) -> np.ndarray:
    """The model's ``<limit velocity>`` per joint; a joint without one (or 0) raises, asking for it."""
    out = []
    for name in names:
        lim = model.joint_map[name].limits
        v = None if lim is None else lim.velocity
        if v is None or not np.isfinite(v) or v <= 0:
            raise TrajectoryError(f"limits.velocity: joint {name!r} has no velocity limit in the model "
                                  f"({v if v is not None else 'none'}): give limits.velocity")
        out.append(float(v))
    return np.array(out)


def check_path_limits(model: RobotModel, path: PiecewisePath, names: Sequence[str], W: np.ndarray) -> None:
    """Refuse waypoints and paths that leave the joint position limits (naming the first joint and where)."""
    lo, hi = model.lower_limits, model.upper_limits
    tol = LIMIT_TOLERANCE
    for m, row in enumerate(W):
        bad = (row < lo - tol) | (row > hi + tol)
        if bad.any():
            j = int(np.argmax(bad))
            raise LimitError(f"waypoints[{m}]: joint {names[j]!r} = {row[j]:g} is outside its limits "
                             f"[{lo[j]:g}, {hi[j]:g}]")
    if path.coeffs.shape[1] <= 4:  # cubic pieces: exact ranges
        t1 = np.diff(path.breaks)[:, None]
        pmin, pmax = poly_range(path.coeffs, np.zeros_like(t1), t1)
        bad = (pmin < lo - tol) | (pmax > hi + tol)
        if bad.any():
            p, j = np.unravel_index(int(np.argmax(bad.ravel())), bad.shape)
            value = pmin[p, j] if pmin[p, j] < lo[j] - tol else pmax[p, j]
            raise LimitError(f"the spline between waypoints {p} and {p + 1} (s in [{path.breaks[p]:.6g}, "
                             f"{path.breaks[p + 1]:.6g}]) takes joint {names[j]!r} to {value:.6g}, outside its "
                             f"limits [{lo[j]:g}, {hi[j]:g}]: add waypoints or use interpolation \"linear\"")
    # a linear path stays in the convex hull of its waypoints: within the limits when they are


def tool_rate(query: Query, tool: ToolSpeed, path: PiecewisePath, W: np.ndarray) -> ToolRate:
    """``|J_v(q) q'|`` of the tool's link origin (or point), world axes, with the chain's reach and
    joint weights that bound its second derivative along ``path`` (:func:`chain_reach`)."""
    poe = compile_model(query.robot)
    T = tool_offset(tool.point, None)

    def rate(Q: np.ndarray, Qp: np.ndarray) -> np.ndarray:
        J = poe.jacobian(Q, tool.link, Reference.LOCAL_WORLD_ALIGNED, tool=T)[:, :3, :]
        return np.linalg.norm(np.einsum("kij,kj->ki", J, Qp), axis=1)

    offset = 0.0 if T is None else float(np.linalg.norm(T[:3, 3]))
    reach, weights = chain_reach(query.robot, tool.link, offset, path_extent(path, W))
    return ToolRate(rate, float(tool.max), reach, weights)


def check_tool_speed(model: RobotModel, tool: ToolSpeed) -> None:
    """Refuse a tool speed limit that is not a positive number or names a link the model lacks."""
    if not np.isfinite(tool.max) or tool.max <= 0:
        raise TrajectoryError(f"limits.tool_speed.max: {tool.max:g}; give a positive speed in m/s")
    model.link_indices([tool.link])


def path_extent(path: PiecewisePath, W: np.ndarray) -> np.ndarray:
    """(dof,) the largest ``|q_i|`` along ``path``: exact for cubic pieces, else the waypoints' (a
    linear path stays in their convex hull)."""
    if path.coeffs.shape[1] <= 4:
        t1 = np.diff(path.breaks)[:, None]
        lo, hi = poly_range(path.coeffs, np.zeros_like(t1), t1)
        return np.maximum(np.abs(lo), np.abs(hi)).max(axis=0)
    return np.abs(W).max(axis=0)


def chain_reach(model: RobotModel, link: str, offset: float, extent: np.ndarray) -> tuple[float, np.ndarray]:
    """``(C, c)`` of :class:`~kinematics.algorithms.trajectory.topp.ToolRate` for the chain from the root
    to ``link`` and a tool point ``offset`` from its origin: ``R`` the sum of the norms of the joint
    origins after the chain's first moving joint, the offset and each prismatic joint's largest
    ``|q|`` (``extent`` (dof,) per joint of q, through its mimic multiplier), ``C = max(1, R)``;
    ``c_i`` the sum of ``|multiplier|`` of the chain's moving joints that joint i drives."""
    weights = np.zeros(len(model.joint_names))
    index = model.q_index
    R = offset
    moved = False
    for joint in model.path_joints(link):
        if moved:
            R += float(np.linalg.norm(joint.origin[:3, 3]))
        if not joint.moving:
            continue
        moved = True
        leader, mult, off = model.resolve_mimic(joint) or (joint.name, 1.0, 0.0)
        weights[index[leader]] += abs(mult)
        if joint.type == "prismatic":
            R += abs(mult) * float(extent[index[leader]]) + abs(off)
    return max(1.0, R), weights


def trajectory(query: Query | RobotModel, waypoints: Any, limits: TrajectoryLimits, interpolation: str = "spline",
               blend: float = 0.0, rate: float = 100.0, grid_points: int = DEFAULT_GRID_POINTS,
               sampling: Sampling = Sampling(), **options: Any) -> TrajectoryAnswer:
    """The trajectory through ``waypoints`` (M >= 2 configurations, any form joint values take) along
    the ``interpolation`` path, timed under ``limits`` and sampled at ``rate`` (Hz) from 0 to its
    duration. Sizes: ``sampling``'s bounds and the answer's numbers within the query's budget
    (``BudgetError``); the planning stops at the current cancellation's time budget."""
    query = Query.of(query, **options)
    model = query.robot
    if model.multi_dof:
        raise TrajectoryError("trajectories take models of one-degree-of-freedom joints (no floating or planar joint)")
    if interpolation not in INTERPOLATIONS:
        raise TrajectoryError(f"interpolation: {interpolation!r} is not one of {', '.join(INTERPOLATIONS)}")
    sampling.check(rate, 0.0)
    if not (np.isfinite(blend) and blend >= 0):
        raise TrajectoryError(f"blend: {blend:g}; give a distance >= 0 (0: stop at each corner)")
    try:
        W, _ = query.replace(limits="report").joints(waypoints)
    except JointValueError as exc:
        raise prefixed(exc, "waypoints: ") from None
    if W.shape[0] < 2:
        raise JointValueError(f"waypoints: {W.shape[0]} configuration(s); a trajectory needs at least 2")
    names = list(model.joint_names)
    velocity = per_joint(limits.velocity, names, "velocity")
    velocity = model_velocity(model, names) if velocity is None else velocity
    if limits.acceleration is None:
        raise TrajectoryError("limits.acceleration is required (a robot description has no acceleration limits)")
    acceleration = per_joint(limits.acceleration, names, "acceleration")
    jerk = per_joint(limits.jerk, names, "jerk")
    if limits.tool_speed is not None:
        check_tool_speed(model, limits.tool_speed)
    path = spline_path(W) if interpolation == "spline" else linear_path(W, blend)
    check_path_limits(model, path, names, W)
    tool = tool_rate(query, limits.tool_speed, path, W) if limits.tool_speed is not None else None
    timing = plan(path, velocity, acceleration, jerk, grid_points, tool)
    sampling.check(rate, timing.duration)
    n = int(np.floor(timing.duration * rate)) + 2
    query.budget.check_result(n * (3 * len(names) + 1), f"{n} samples x (3 x {len(names)} joints + 1)")
    t = sample_times(timing.duration, rate)
    q, qd, qdd, _ = timing.sample(t)
    optimal = plan(path, velocity, acceleration, None, grid_points, tool).duration if jerk is not None else None
    used = {"velocity": velocity, "acceleration": acceleration, "jerk": jerk}
    if limits.tool_speed is not None:
        used["tool_speed"] = {"link": limits.tool_speed.link, "max": float(limits.tool_speed.max),
                              "point": None if limits.tool_speed.point is None else list(limits.tool_speed.point)}
    return TrajectoryAnswer(model, names, timing.duration, t, q, qd, qdd, timing.method, used, path, timing, optimal)
