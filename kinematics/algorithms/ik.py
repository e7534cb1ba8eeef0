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
from ..tolerances import LIMIT_TOLERANCE
from ..spatial.rotations import rotation_angle
from ..spatial.transforms import inverse_transform

#: what a target constrains: the full pose, or the position only (orientation free)
IK_MODES = ("pose", "position")
#: default tolerances: metres, and radians of the rotation between answer and target
DEFAULT_POSITION_TOLERANCE = 1e-6
DEFAULT_ROTATION_TOLERANCE = 1e-6
#: default steps per attempt and random restarts after the first attempt
DEFAULT_MAX_ITERATIONS = 100
DEFAULT_RESTARTS = 50
#: the smallest damping λ (added to ½|e|²): keeps steps bounded at singular configurations
DAMPING = 1e-9
#: an attempt goes on until its errors are this fraction of the tolerances (one more cheap
#: step near convergence), so that answers are not on the edge of their tolerance
POLISH = 1e-3
#: steps without a 1 % fall of the error after which an attempt counts as stuck and restarts
STALL_STEPS = 12
#: tolerances below this are refused: no FK is that exact
MIN_TOLERANCE = 1e-12


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
    poe = compile_model(model)
    li = int(poe.link_indices([link])[0])
    targets = np.asarray(targets, dtype=float).reshape(-1, 4, 4)
    N = targets.shape[0]
    T_root = targets if base is None else np.matmul(inverse_transform(base), targets)
    if seeds is None:
        seeds = middle_of_limits(model)
    Q0 = np.ascontiguousarray(np.broadcast_to(np.asarray(seeds, dtype=float), (N, model.dof)))
    T_root = np.ascontiguousarray(T_root)
    Q, _, _, steps = poe.kernel.ik(
        Q0, T_root, li, model.lower_limits, model.upper_limits, model.continuous, model.angular,
        mode == "position", float(position_tolerance), float(rotation_tolerance), int(max_iterations),
        int(restarts), ik_kernel.streams(T_root, Q0, np.uint64(int(random_seed) & 0xFFFFFFFFFFFFFFFF)), DAMPING, POLISH, STALL_STEPS, tool=tool)
    # the answer's own errors, measured on its pose from the FK kernel: success is only what they show
    position, rotation, success = np.empty(N), np.empty(N), np.empty(N, dtype=np.bool_)
    ik_kernel.measure(poe.fk(Q, [link], tool=tool)[:, 0], T_root, Q, model.lower_limits, model.upper_limits, LIMIT_TOLERANCE,
                      float(position_tolerance), float(rotation_tolerance), mode == "position", position, rotation,
                      success)
    return IKSolution(Q, success, position, rotation, steps)
