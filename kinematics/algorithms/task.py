"""Task vectors ``r = (p, phi)`` and analytic Jacobians ``J_r = dr/dq`` (numeric, batched).

A task vector stacks the position ``p`` of a link's origin (world axes) and an orientation
``phi`` in one of these representations, or any subset of their components (De Luca's
Robotics 1 slides: "r = f_r(q)", m <= 6 components chosen for the task):

==============  ============================  ===========================================
representation  components of phi            rotation
==============  ============================  ===========================================
``rpy``         ``roll, pitch, yaw``          URDF: ``R = Rz(yaw) Ry(pitch) Rx(roll)``
``zyx``         ``alpha_z, beta_y, gamma_x``  ZYX Euler: ``R = Rz(alpha) Ry(beta) Rx(gamma)``
``zyz``         ``phi, theta, psi``           ZYZ Euler: ``R = Rz(phi) Ry(theta) Rz(psi)``
``quaternion``  ``qw, qx, qy, qz``            unit quaternion, ``qw >= 0``
``rotvec``      ``rx, ry, rz``                rotation vector ``theta u`` (``theta`` in [0, pi])
==============  ============================  ===========================================

The position components are ``px, py, pz``. Named subsets: ``position`` = ``(px, py, pz)``;
``scara`` = ``(px, py, pz, alpha_z)`` (De Luca's SCARA: ``alpha_z = q1 + q2 + q4``);
``planar`` = ``(px, py, phi)`` with ``phi = alpha_z`` (the planar arms: ``phi = q1 + q2``).

The analytic Jacobian is ``J_r = blockdiag(I, E(phi)^-1) J`` with ``J`` the geometric
Jacobian (``local_world_aligned``: origin velocity and angular velocity in world axes) and
``omega = E(phi) phi_dot``:

- ``rpy`` / ``zyx``: ``E = [Rz Ry e_x, Rz e_y, e_z]`` (columns for roll, pitch, yaw), ``det E = cos(pitch)``;
- ``zyz``: ``E = [e_z, Rz(phi) e_y, Rz(phi) Ry(theta) e_z]``, ``|det E| = sin(theta)``;
- ``quaternion``: ``q_dot = 1/2 [-v^T; w I - [v]] omega`` (``v = (qx, qy, qz)``; the sign convention
  ``qw >= 0`` flips at ``qw = 0``);
- ``rotvec``: ``r_dot = J_l(r)^-1 omega`` with ``J_l^-1 = I - [r]/2 + (1/theta^2 - (1 + cos theta) /
  (2 theta sin theta)) [r]^2``, singular at ``theta = pi``.

Where ``E`` is not invertible (Euler angles at their gimbal lock, a rotation vector at a
half turn, a quaternion at ``qw = 0``) and a chosen orientation component needs it,
:class:`~kinematics.errors.RepresentationSingularityError` names the configuration.

The 2R planar arm (``a1 = 0.5``, ``a2 = 0.4``) at ``q = (0, pi/2)``: ``r = (a1 c1 + a2 c12,
a1 s1 + a2 s12, q1 + q2)`` and ``J_r = [[-a1 s1 - a2 s12, -a2 s12], [a1 c1 + a2 c12, a2 c12], [1, 1]]``:

>>> from kinematics.io import default_catalogue
>>> planar = default_catalogue().get("planar_2r")
>>> r, Jr = task(planar, [[0.0, np.pi / 2]], "tool", task_representation("planar"))
>>> r.round(12) + 0.0
array([[0.5       , 0.4       , 1.57079633]])
>>> Jr[0].round(12) + 0.0
array([[-0.4, -0.4],
       [ 0.5,  0. ],
       [ 1. ,  1. ]])
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..errors import RepresentationSingularityError, TaskError
from ..model.robot import RobotModel
from ..spatial.reference import Reference
from ..spatial.rotations import matrix_to_quaternion, matrix_to_rpy, skew
from ..tolerances import REPRESENTATION_SINGULARITY_TOLERANCE
from .base import jacobian_in_world, poses_in_world
from .fk import forward_kinematics
from .jacobian import jacobian as _jacobian

POSITION_COMPONENTS = ("px", "py", "pz")
#: orientation components of each rotation representation
ROTATION_COMPONENTS: dict[str, tuple[str, ...]] = {
    "rpy": ("roll", "pitch", "yaw"),
    "zyx": ("alpha_z", "beta_y", "gamma_x"),
    "zyz": ("phi", "theta", "psi"),
    "quaternion": ("qw", "qx", "qy", "qz"),
    "rotvec": ("rx", "ry", "rz"),
}
#: named subsets: (rotation representation, components, display names)
PRESETS: dict[str, tuple[str | None, tuple[str, ...], tuple[str, ...]]] = {
    "position": (None, POSITION_COMPONENTS, POSITION_COMPONENTS),
    "scara": ("zyx", ("px", "py", "pz", "alpha_z"), ("px", "py", "pz", "alpha_z")),
    "planar": ("zyx", ("px", "py", "alpha_z"), ("px", "py", "phi")),
}
REPRESENTATIONS: tuple[str, ...] = tuple(ROTATION_COMPONENTS) + tuple(PRESETS)
#: components that are angles (compared modulo 2 pi)
ANGLE_COMPONENTS = frozenset({"roll", "pitch", "yaw", "alpha_z", "beta_y", "gamma_x", "phi", "theta", "psi"})


@dataclass(frozen=True)
class TaskRepresentation:
    """A task vector's layout: the rotation representation (``None``: position only), the
    components kept (internal names, in order) and their display names."""

    name: str
    rotation: str | None
    components: tuple[str, ...]
    labels: tuple[str, ...]

    @property
    def size(self) -> int:
        return len(self.components)

    @property
    def angles(self) -> tuple[bool, ...]:
        """Per component: an angle (compare modulo 2 pi)."""
        return tuple(c in ANGLE_COMPONENTS for c in self.components)


def task_representation(representation: str = "rpy", components: Sequence[str] | None = None) -> TaskRepresentation:
    """The layout of ``representation`` (a rotation representation or a named subset), keeping
    ``components`` (names of :data:`POSITION_COMPONENTS` and of the representation's angles; default all).

    >>> task_representation("scara").labels
    ('px', 'py', 'pz', 'alpha_z')
    >>> task_representation("zyz", ["pz", "theta"]).components
    ('pz', 'theta')
    """
    if not isinstance(representation, str) or representation not in REPRESENTATIONS:
        raise TaskError(f"representation: {representation!r} is not one of {list(REPRESENTATIONS)}")
    if representation in PRESETS:
        rotation, comps, labels = PRESETS[representation]
        if components is None:
            return TaskRepresentation(representation, rotation, comps, labels)
        available = dict(zip(labels, comps))
    else:
        rotation = representation
        comps = POSITION_COMPONENTS + ROTATION_COMPONENTS[representation]
        if components is None:
            return TaskRepresentation(representation, rotation, comps, comps)
        available = {c: c for c in comps}
    if isinstance(components, str) or not isinstance(components, Sequence) or not components:
        raise TaskError(f"components: expected a non-empty list of names from {list(available)}")
    chosen, labels = [], []
    for i, c in enumerate(components):
        if c not in available:
            raise TaskError(f"components[{i}]: {c!r} is not a component of {representation!r} "
                            f"(one of {list(available)})")
        if c in labels:
            raise TaskError(f"components[{i}]: {c!r} is given twice")
        chosen.append(available[c])
        labels.append(c)
    return TaskRepresentation(representation, rotation, tuple(chosen), tuple(labels))


# ---------------------------------------------------------------------- orientation
def _zyz(R: np.ndarray) -> np.ndarray:
    """ZYZ Euler angles (N, 3) of rotations R (N, 3, 3), theta in [0, pi]; at theta = 0 or pi, phi = 0."""
    s = np.hypot(R[:, 0, 2], R[:, 1, 2])
    theta = np.arctan2(s, R[:, 2, 2])
    regular = s > 1e-12
    phi = np.where(regular, np.arctan2(R[:, 1, 2], R[:, 0, 2]), 0.0)
    psi_regular = np.arctan2(R[:, 2, 1], -R[:, 2, 0])
    psi_flat = np.where(R[:, 2, 2] > 0, np.arctan2(R[:, 1, 0], R[:, 0, 0]), np.arctan2(R[:, 1, 0], R[:, 1, 1]))
    psi = np.where(regular, psi_regular, psi_flat)
    return np.stack([phi, theta, psi], axis=-1)


def _rotvec(R: np.ndarray) -> np.ndarray:
    """Rotation vectors (N, 3), angle in [0, pi], from the quaternion (w >= 0)."""
    quat = matrix_to_quaternion(R)
    w, v = quat[:, 0], quat[:, 1:]
    n = np.linalg.norm(v, axis=-1)
    factor = np.where(n > 1e-12, 2.0 * np.arctan2(n, w) / np.where(n > 1e-12, n, 1.0), 2.0 / np.maximum(w, 1e-300))
    return factor[:, None] * v


def _orientation(R: np.ndarray, rotation: str) -> dict[str, np.ndarray]:
    if rotation in ("rpy", "zyx"):
        a = matrix_to_rpy(R)
        return {"roll": a[:, 0], "pitch": a[:, 1], "yaw": a[:, 2],
                "gamma_x": a[:, 0], "beta_y": a[:, 1], "alpha_z": a[:, 2]}
    if rotation == "zyz":
        a = _zyz(R)
        return {"phi": a[:, 0], "theta": a[:, 1], "psi": a[:, 2]}
    if rotation == "quaternion":
        a = matrix_to_quaternion(R)
        return {"qw": a[:, 0], "qx": a[:, 1], "qy": a[:, 2], "qz": a[:, 3]}
    a = _rotvec(R)
    return {"rx": a[:, 0], "ry": a[:, 1], "rz": a[:, 2]}


def task_vector(T: np.ndarray, rep: TaskRepresentation) -> np.ndarray:
    """Task vectors (N, m) of poses ``T`` (N, 4, 4) in the layout ``rep``."""
    T = np.asarray(T, dtype=float).reshape(-1, 4, 4)
    values = {"px": T[:, 0, 3], "py": T[:, 1, 3], "pz": T[:, 2, 3]}
    if rep.rotation is not None and any(c not in values for c in rep.components):
        values.update(_orientation(T[:, :3, :3], rep.rotation))
    return np.stack([values[c] for c in rep.components], axis=-1)


def _singular(k: int, rep: TaskRepresentation, why: str) -> RepresentationSingularityError:
    return RepresentationSingularityError(
        f"the {rep.rotation} representation is singular at configuration {k} ({why}): E(phi) is not invertible "
        "there, so dr/dq is undefined; choose another representation or configuration")


def _refuse_singular(singular: np.ndarray, rep: TaskRepresentation, why: str) -> None:
    """Refuse (:class:`RepresentationSingularityError`) the first configuration where ``singular`` (N,) holds."""
    bad = np.flatnonzero(singular)
    if bad.size:
        raise _singular(int(bad[0]), rep, why)


def _rates(R: np.ndarray, rotation: str, rep: TaskRepresentation, need: set[str]) -> dict[str, np.ndarray]:
    """Per orientation component, the row (N, 3) mapping the angular velocity to its rate."""
    tol = REPRESENTATION_SINGULARITY_TOLERANCE
    N = R.shape[0]
    if rotation in ("rpy", "zyx"):
        a = matrix_to_rpy(R)
        p, y = a[:, 1], a[:, 2]
        cp, sp_, cy, sy = np.cos(p), np.sin(p), np.cos(y), np.sin(y)
        _refuse_singular(np.abs(cp) < tol, rep, "pitch at +-90 degrees, the gimbal lock")
        # E = [[cy cp, -sy, 0], [sy cp, cy, 0], [-sp, 0, 1]] (columns roll, pitch, yaw); its inverse:
        z = np.zeros(N)
        roll = np.stack([cy / cp, sy / cp, z], axis=-1)
        pitch = np.stack([-sy, cy, z], axis=-1)
        yaw = np.stack([cy * sp_ / cp, sy * sp_ / cp, np.ones(N)], axis=-1)
        return {"roll": roll, "pitch": pitch, "yaw": yaw, "gamma_x": roll, "beta_y": pitch, "alpha_z": yaw}
    if rotation == "zyz":
        a = _zyz(R)
        f, t = a[:, 0], a[:, 1]
        cf, sf, ct, st = np.cos(f), np.sin(f), np.cos(t), np.sin(t)
        _refuse_singular(np.abs(st) < tol, rep, "theta at 0 or 180 degrees: phi and psi turn about one axis")
        # E = [[0, -sf, cf st], [0, cf, sf st], [1, 0, ct]] (columns phi, theta, psi); its inverse:
        z = np.zeros(N)
        phi = np.stack([-cf * ct / st, -sf * ct / st, np.ones(N)], axis=-1)
        theta = np.stack([-sf, cf, z], axis=-1)
        psi = np.stack([cf / st, sf / st, z], axis=-1)
        return {"phi": phi, "theta": theta, "psi": psi}
    if rotation == "quaternion":
        qv = matrix_to_quaternion(R)
        w, x, y, zq = qv[:, 0], qv[:, 1], qv[:, 2], qv[:, 3]
        _refuse_singular(w < tol, rep, "a half turn, qw = 0, where the sign convention qw >= 0 flips")
        return {"qw": 0.5 * np.stack([-x, -y, -zq], axis=-1), "qx": 0.5 * np.stack([w, zq, -y], axis=-1),
                "qy": 0.5 * np.stack([-zq, w, x], axis=-1), "qz": 0.5 * np.stack([y, -x, w], axis=-1)}
    r = _rotvec(R)
    theta = np.linalg.norm(r, axis=-1)
    _refuse_singular(np.pi - theta < tol, rep, "a half turn, theta = 180 degrees")
    K = skew(r)
    small = theta < 1e-6
    th = np.where(small, 1.0, theta)
    coef = np.where(small, 1.0 / 12.0 + theta**2 / 720.0,
                    1.0 / th**2 - (1.0 + np.cos(th)) / (2.0 * th * np.sin(th)))
    Jinv = np.eye(3) - 0.5 * K + coef[:, None, None] * (K @ K)
    return {"rx": Jinv[:, 0], "ry": Jinv[:, 1], "rz": Jinv[:, 2]}


def analytic_jacobian(T: np.ndarray, J: np.ndarray, rep: TaskRepresentation) -> np.ndarray:
    """``J_r`` (N, m, n) from poses ``T`` (N, 4, 4) and their geometric Jacobians ``J`` (N, 6, n)
    (``local_world_aligned``, linear rows first): ``J_r = blockdiag(I, E(phi)^-1) J``, rows as ``rep``."""
    T = np.asarray(T, dtype=float).reshape(-1, 4, 4)
    J = np.asarray(J, dtype=float)
    rows = {"px": J[:, 0], "py": J[:, 1], "pz": J[:, 2]}
    need = {c for c in rep.components if c not in rows}
    if need:
        rates = _rates(T[:, :3, :3], rep.rotation, rep, need)
        Jw = J[:, 3:]
        for c in need:
            rows[c] = np.einsum("nk,nkj->nj", rates[c], Jw)
    return np.stack([rows[c] for c in rep.components], axis=1)


def task(model: RobotModel, Q, link: str, rep: TaskRepresentation, base: np.ndarray | None = None,
         tool: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(r (N, m), J_r (N, m, dof))`` of ``link`` at joint values ``Q`` (N, dof); ``base``:
    ``T_world_root`` per configuration, or None for the root frame; ``tool``: ``T_link_tool``
    (4x4, or None): the task vector of that frame instead of the link's."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    T = poses_in_world(forward_kinematics(model, Q, [link], tool=tool), base)[:, 0]
    J = jacobian_in_world(_jacobian(model, Q, link, Reference.LOCAL_WORLD_ALIGNED, tool=tool), base,
                          Reference.LOCAL_WORLD_ALIGNED)
    return task_vector(T, rep), analytic_jacobian(T, J, rep)
