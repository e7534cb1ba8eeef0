"""Inverse kinematics: the joint values that put a link at a target pose.

For N targets ``T_world_link`` of one link, :func:`inverse_kinematics` runs the compiled
damped-least-squares solver (:mod:`kinematics.engine.ik`) from the seeds (given, or the middle
of the limits), with random restarts within the limits when an attempt does not converge. The
limits are part of every step (no out-of-limit iterate), continuous joints wrap, only the
joints on the root-to-link path move, and mimic joints follow their leaders.

**Success is measured again, independently of the solver**: the answer's FK (the regular FK
kernel) must be within the tolerances of the target (position in metres; rotation as the angle
of ``R_target^T R``, in radians; ignored in ``position`` mode) *and* every joint value inside its
limits. The reported errors are those of that check.

The 2R planar arm (``a1 = 0.5``, ``a2 = 0.4``) reaching ``(0.3, 0.6)`` in position mode:

>>> import numpy as np
>>> from kinematics.io import default_catalogue
>>> planar = default_catalogue().get("planar_2r")
>>> target = np.eye(4)[None].copy(); target[0, :3, 3] = [0.3, 0.6, 0.0]
>>> sol = inverse_kinematics(planar, "tool", target, mode="position")
>>> bool(sol.success[0]), bool(sol.position_error[0] < 1e-6)
(True, True)
>>> q1, q2 = sol.q[0]
>>> float(round(0.5 * np.cos(q1) + 0.4 * np.cos(q1 + q2), 9)), float(round(0.5 * np.sin(q1) + 0.4 * np.sin(q1 + q2), 9))
(0.3, 0.6)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..engine import ik as ik_kernel
from ..engine.poe import compile_model
from ..errors import KinematicsError
from ..model.derived import PerModel
from ..model.robot import RobotModel
from ..tolerances import (  # noqa: F401  (the IK tolerances are part of this module's interface)
    DAMPING,
    DEFAULT_POSITION_TOLERANCE,
    DEFAULT_ROTATION_TOLERANCE,
    LIMIT_TOLERANCE,
    MIN_TOLERANCE,
    POLISH,
)
from ..spatial.rotations import rotation_angle
from ..spatial.transforms import inverse_transform

#: what a target constrains: the full pose, or the position only (orientation free)
IK_MODES = ("pose", "position")
#: default steps per attempt and random restarts after the first attempt
DEFAULT_MAX_ITERATIONS = 100
DEFAULT_RESTARTS = 50
#: steps without a 1 % fall of the error after which an attempt counts as stuck and restarts
STALL_STEPS = 12


@dataclass(frozen=True, eq=False)
class IKSolution:
    """Answers for N targets: ``q`` (N, dof), ``success`` (N,) bool, ``position_error`` (N,)
    metres, ``rotation_error`` (N,) radians (measured on the answer), ``iterations`` (N,) steps
    over all attempts."""

    q: np.ndarray
    success: np.ndarray
    position_error: np.ndarray
    rotation_error: np.ndarray
    iterations: np.ndarray


def pose_errors(T: np.ndarray, targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position distance (N,) and rotation angle (N,) between poses ``T`` and ``targets`` (N, 4, 4)."""
    position = np.linalg.norm(targets[:, :3, 3] - T[:, :3, 3], axis=1)
    rotation = rotation_angle(np.swapaxes(targets[:, :3, :3], 1, 2) @ T[:, :3, :3])
    return position, rotation


def middle_of_limits(model: RobotModel) -> np.ndarray:
    """The default seed (dof,): the middle of each joint's limits (0 where a joint has none)."""
    return _middles(model)


def _middle(model: RobotModel) -> np.ndarray:
    lo, hi = model.lower_limits, model.upper_limits
    limited = np.isfinite(lo) & np.isfinite(hi)
    middle = np.where(limited, 0.5 * (np.where(limited, lo, 0.0) + np.where(limited, hi, 0.0)), 0.0)
    middle.setflags(write=False)
    return middle


_middles = PerModel(_middle)


def inverse_kinematics(model: RobotModel, link: str, targets: np.ndarray, seeds: np.ndarray | None = None, *,
                       base: np.ndarray | None = None, mode: str = "pose",
                       position_tolerance: float = DEFAULT_POSITION_TOLERANCE,
                       rotation_tolerance: float = DEFAULT_ROTATION_TOLERANCE,
                       max_iterations: int = DEFAULT_MAX_ITERATIONS, restarts: int = DEFAULT_RESTARTS,
                       random_seed: int = 0, tool: np.ndarray | None = None) -> IKSolution:
    """Joint values putting ``link`` at ``targets`` (N, 4, 4) ``T_world_link``.

    ``tool``: ``T_link_tool`` (4, 4); the targets are then poses of that tool frame
    (``T_world_link @ T_link_tool``), the errors measured on it.

    ``seeds``: (N, dof) or (dof,) starting values (default: the middle of the limits); joints
    off the link's path keep them. ``base``: ``T_world_root`` (N, 4, 4), or None.
    ``random_seed``: the restarts' random draws (the same inputs give the same answers).
    """
    if mode not in IK_MODES:
        raise KinematicsError(f"mode: {mode!r} is not one of {', '.join(IK_MODES)}")
    for name, tol in (("tolerance.position", position_tolerance), ("tolerance.rotation", rotation_tolerance)):
        if not (np.isfinite(tol) and tol >= MIN_TOLERANCE):
            raise KinematicsError(f"{name}: {tol!r}; give a finite tolerance of at least {MIN_TOLERANCE:g}")
    if max_iterations < 1 or restarts < 0:
        raise KinematicsError(f"max_iterations must be at least 1 and restarts at least 0 "
                              f"(got {max_iterations}, {restarts})")
    if model.multi_dof:
        return tree_inverse_kinematics(model, link, targets, seeds, base=base, mode=mode,
                                       position_tolerance=position_tolerance, rotation_tolerance=rotation_tolerance,
                                       max_iterations=max_iterations, restarts=restarts, random_seed=random_seed,
                                       tool=tool)
    poe, li, T_root, Q0 = _problem(model, link, targets, base, middle_of_limits(model) if seeds is None else seeds)
    N = T_root.shape[0]
    Q0 = np.ascontiguousarray(Q0)
    T_root = np.ascontiguousarray(T_root)
    joints = (model.lower_limits, model.upper_limits, model.continuous, model.angular)
    settings = (mode == "position", float(position_tolerance), float(rotation_tolerance), int(max_iterations),
                int(restarts), DAMPING, POLISH, STALL_STEPS)
    streams = ik_kernel.streams(T_root, Q0, np.uint64(int(random_seed) & 0xFFFFFFFFFFFFFFFF))
    Q, _, _, steps = poe.kernel.ik(Q0, T_root, li, joints, settings, streams, tool=tool)
    # the answer's own errors, measured on its pose from the FK kernel: success is only what they show
    position, rotation, success = np.empty(N), np.empty(N), np.empty(N, dtype=np.bool_)
    ik_kernel.measure(poe.fk(Q, [link], tool=tool)[:, 0], T_root, Q, model.lower_limits, model.upper_limits, LIMIT_TOLERANCE,
                      float(position_tolerance), float(rotation_tolerance), mode == "position", position, rotation,
                      success)
    return IKSolution(Q, success, position, rotation, steps)


# ---------------------------------------------------------------------- models with floating or planar joints
def _middle_neutral(model: RobotModel) -> np.ndarray:
    """The default seed of a multi-dof model (nq,): the neutral configuration, one-dof joints at the
    middle of their limits."""
    q = np.array(model.neutral)
    middle = _middle(model)
    for s in model.layout:
        if s.nq == 1:
            q[s.q_start] = middle[s.q_start]
    q.setflags(write=False)
    return q


_neutral_middles = PerModel(_middle_neutral)


def _target_rng(target: np.ndarray, random_seed: int) -> np.random.Generator:
    """A generator seeded by the target's bytes and ``random_seed`` (a target solved alone gets its batch answer)."""
    words = np.frombuffer(np.ascontiguousarray(target, dtype=np.float64).tobytes(), dtype=np.uint32)
    return np.random.default_rng([int(random_seed) & 0xFFFFFFFF, *words.tolist()])


def _random_restart(model: RobotModel, q: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A restart point: one-dof joints uniform within their limits (±π when unbounded), floating and
    planar joints keep their position and take a random orientation (angle)."""
    q = q.copy()
    for s in model.layout:
        if s.nq == 1:
            lo, hi = model.lower_limits[s.q_start], model.upper_limits[s.q_start]
            lo = lo if np.isfinite(lo) else -np.pi
            hi = hi if np.isfinite(hi) else np.pi
            q[s.q_start] = rng.uniform(lo, hi)
        elif s.type == "floating":
            quat = rng.normal(size=4)
            q[s.q_start + 3:s.q_start + 7] = quat / np.linalg.norm(quat)
        else:
            theta = rng.uniform(-np.pi, np.pi)
            q[s.q_start + 2], q[s.q_start + 3] = np.cos(theta), np.sin(theta)
    return q


def _project(model: RobotModel, Q: np.ndarray) -> np.ndarray:
    """One-dof entries put back within their limits, continuous angles wrapped into [-π, π]."""
    lo, hi = model.lower_limits, model.upper_limits
    Q = np.clip(Q, lo, hi)  # infinite bounds leave floating and planar entries unchanged
    cont = model.continuous
    if cont.any():
        Q[:, cont] = np.mod(Q[:, cont] + np.pi, 2 * np.pi) - np.pi
    return Q


def _errors(F: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """(N, 6) position error and rotation vector of ``R_target R^T`` (world axes)."""
    from ..spatial.lie import so3_log

    e = np.empty((F.shape[0], 6))
    e[:, :3] = targets[:, :3, 3] - F[:, :3, 3]
    e[:, 3:] = so3_log(targets[:, :3, :3] @ np.swapaxes(F[:, :3, :3], 1, 2))
    return e


def _problem(model: RobotModel, link: str, targets, base, seeds):
    """``(compiled model, link index, T_root (N, 4, 4), Q0 (N, nq))`` of an IK request: the targets in the
    root frame (``base`` taken off) and one (writable) copy of the seeds per target."""
    compiled = compile_model(model)
    li = int(compiled.link_indices([link])[0])
    targets = np.asarray(targets, dtype=float).reshape(-1, 4, 4)
    T_root = targets if base is None else np.matmul(inverse_transform(base), targets)
    Q0 = np.array(np.broadcast_to(np.asarray(seeds, dtype=float), (targets.shape[0], model.nq)))
    return compiled, li, T_root, Q0


def tree_inverse_kinematics(model: RobotModel, link: str, targets: np.ndarray, seeds: np.ndarray | None = None, *,
                            base: np.ndarray | None = None, mode: str = "pose",
                            position_tolerance: float = DEFAULT_POSITION_TOLERANCE,
                            rotation_tolerance: float = DEFAULT_ROTATION_TOLERANCE,
                            max_iterations: int = DEFAULT_MAX_ITERATIONS, restarts: int = DEFAULT_RESTARTS,
                            random_seed: int = 0, tool: np.ndarray | None = None) -> IKSolution:
    """IK of a model with floating or planar joints (numpy; :func:`inverse_kinematics` calls it).

    Damped least squares on the manifold: per step ``(J^T J + λ I) Δv = J^T e`` with ``J`` the
    ``local_world_aligned`` Jacobian (nv columns), ``e`` the position error and the rotation vector
    of ``R_target R^T`` (position rows only in ``position`` mode) and ``λ = ½|e|² + DAMPING``;
    then ``q ← q ⊕ Δv`` (:meth:`~kinematics.engine.tree.TreeModel.integrate`: the quaternion
    exponential of a floating joint, the angle of a planar one), one-dof joints clipped to their
    limits and continuous ones wrapped. Restarts, success and the answer's errors as
    :func:`inverse_kinematics` (measured again by FK).
    """
    from ..model.joint_values import limit_violations

    eng, li, T_root, Q = _problem(model, link, targets, base, _neutral_middles(model) if seeds is None else seeds)
    N = T_root.shape[0]
    Q = _project(model, Q)
    position_only = mode == "position"
    rows = slice(0, 3) if position_only else slice(0, 6)
    tool_T = None if tool is None else np.asarray(tool, dtype=float)
    goal_p, goal_r = POLISH * position_tolerance, POLISH * rotation_tolerance
    steps = np.zeros(N, dtype=np.int64)
    best_Q = Q.copy()
    best_score = np.full(N, np.inf)
    solved = np.zeros(N, dtype=bool)
    rngs = [None] * N

    def measure(Qm, Tm):
        F = eng.fk(Qm, [link], tool=tool_T)[:, 0]
        p, r = pose_errors(F, Tm)
        if position_only:
            r = np.zeros_like(r)
        ok = (p <= position_tolerance) & (r <= rotation_tolerance) & ~limit_violations(model, Qm).any(axis=1)
        return p, r, ok

    for attempt in range(restarts + 1):
        run = np.flatnonzero(~solved)
        if run.size == 0:
            break
        if attempt > 0:
            for n in run:
                if rngs[n] is None:
                    rngs[n] = _target_rng(T_root[n], random_seed)
                Q[n] = _random_restart(model, best_Q[n] if np.isfinite(best_score[n]) else Q[n], rngs[n])
            Q[run] = _project(model, Q[run])
        active = run.copy()
        for _ in range(max_iterations):
            if active.size == 0:
                break
            Qa = Q[active]
            frames = eng.frames(Qa)
            F = frames[:, li] if tool_T is None else frames[:, li] @ tool_T
            e = _errors(F, T_root[active])
            done = (np.linalg.norm(e[:, :3], axis=1) <= goal_p) & (
                position_only | (np.linalg.norm(e[:, 3:], axis=1) <= goal_r))
            active, Qa, frames, e = active[~done], Qa[~done], frames[~done], e[~done]
            if active.size == 0:
                break
            J = eng.jacobian(Qa, link, "local_world_aligned", tool=tool_T, frames=frames)[:, rows]
            e = e[:, rows]
            lam = 0.5 * np.sum(e * e, axis=1) + DAMPING
            A = np.swapaxes(J, 1, 2) @ J + lam[:, None, None] * np.eye(model.nv)
            dv = np.linalg.solve(A, (np.swapaxes(J, 1, 2) @ e[:, :, None]))[:, :, 0]
            Q[active] = _project(model, eng.integrate(Qa, dv))
            steps[active] += 1
        p, r, ok = measure(Q[run], T_root[run])
        score = np.where(ok, -1.0, p + r)
        better = score < best_score[run]
        best_Q[run[better]] = Q[run[better]]
        best_score[run[better]] = score[better]
        solved[run[ok]] = True
    position, rotation, success = measure(best_Q, T_root)
    if position_only:
        rotation = pose_errors(eng.fk(best_Q, [link], tool=tool_T)[:, 0], T_root)[1]
    return IKSolution(best_Q, success, position, rotation, steps)
