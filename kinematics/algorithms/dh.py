"""Denavit-Hartenberg kinematics: the product of a table's matrices, and URDF -> DH.

The product (:func:`dh_transforms`, :func:`dh_tool_pose`) is the definition a DH model's
URDF is tested against: standard ``A_i = Rot_z(theta_i) Trans_z(d_i) Trans_x(a_i)
Rot_x(alpha_i)``, modified ``A_i = Rot_x(alpha_{i-1}) Trans_x(a_{i-1}) Rot_z(theta_i)
Trans_z(d_i)``, and ``T_world_tool = base A_1 ... A_n tool``.

URDF -> DH (:func:`urdf_to_dh`): the table of a serial chain, following its joint axes.

The chain is the path from the root link to ``tip`` (the only leaf when not given). At
q = 0 every moving joint on it gives a line in the world frame: its axis direction ``w_k``
through the joint origin (for a prismatic joint only the direction matters; the line
through the joint origin is used). Frames are then placed on these lines as in Wen's
Robotics I notes ("DH and modified DH") and De Luca's Robotics 1 slides ("ambiguities in
defining DH frames"):

- consecutive axes **not parallel**: the x axis is the common normal
  ``x = (w_k x w_{k+1}) / |w_k x w_{k+1}|`` (intersecting axes: ``a = 0``), placed at the
  feet of the common perpendicular; ``a`` is the signed distance along x;
- **parallel** axes: the common normal is not unique; the one through the previous frame's
  origin is used (standard: ``d_i = 0``; modified: ``d_i = 0``), x points from axis k to
  axis k+1 (anti-parallel axes give ``alpha = pi``);
- **coincident** axes (a P/R pair on one line): x is kept from the previous frame
  (``a = 0``, ``alpha = 0`` or ``pi``, ``theta`` offset 0) and the origin stays;
- frame 0: z on axis 1, origin at the foot of the world origin on axis 1, x from the world
  x axis (world y if x is along axis 1); ``base = T_world_frame0`` is the identity when
  axis 1 is the world z axis;
- the last frame: origin at the tip's origin when it is off the last axis (x points to it),
  else at its foot on the axis with x from the tip's x axis; ``tool = T_frameN_tip``.

Every frame is attached to the link its joint axes belong to, so the table's FK with
``base``/``tool`` equals the URDF's FK of ``tip`` at every configuration (same q, same
joint names, the URDF's limits). The DH offsets (``theta`` of revolute rows, ``d`` of
prismatic rows) absorb the zero-configuration geometry. :func:`urdf_to_dh` verifies the
result at q = 0 and at random configurations and refuses (``NoDHFormError``) a chain whose
table would deviate by more than :data:`~kinematics.tolerances.AGREEMENT_TOLERANCE` (nearly-parallel axes make the
DH form ill-conditioned).

Fixed joints are folded in (they only move the lines). Refused with ``NoDHFormError``: a
tree without a chosen tip (more than one leaf), a mimic joint on the chain, a chain without
moving joints.
"""

from __future__ import annotations

import math

import numpy as np

from ..engine.poe import compile_model
from ..errors import DHError, NoDHFormError, UnknownLinkError, did_you_mean
from ..io.dh_table import CONVENTIONS, DHRow, DHTable
from ..model.robot import RobotModel, frozen_array
from ..tolerances import AGREEMENT_TOLERANCE, MAX_ABS_COORDINATE

#: |w_k x w_{k+1}| below this: the axes are treated as parallel
PARALLEL_TOLERANCE = 1e-9
#: distance (m) below which two parallel lines are coincident / a point is on a line
COINCIDENT_TOLERANCE = 1e-12
#: configurations (besides q = 0) at which the extracted table is verified
VERIFY_SAMPLES = 8
#: parameters closer than this to 0 (m) or to a multiple of pi/2 (rad) are snapped to it
SNAP_TOLERANCE = 1e-13
#: relative rounding allowed when a perpendicular offset is computed from a difference
_ROUNDING = 1e-14
#: x @ x_prev below -this flips the new x (ties keep the cross product's sign)
_SIGN_EPS = 1e-9
#: below this norm a projected candidate axis is not used to pick an x direction
_PICK_MIN_NORM = 1e-6


def _as_q(table: DHTable, Q) -> np.ndarray:
    Q = np.asarray(Q, dtype=float)
    if Q.ndim == 1:
        Q = Q[None, :]
    if Q.ndim != 2 or Q.shape[1] != table.dof:
        raise DHError(f"expected joint values of shape (N, {table.dof}), got {np.shape(Q)}")
    return Q


def dh_row_transforms(table: DHTable, Q) -> np.ndarray:
    """The matrices ``A_i(q_i)`` (N, n, 4, 4), ``T_frame{i-1}_frame{i}``, for a batch ``Q`` (N, n)."""
    Q = _as_q(table, Q)
    N, n = Q.shape
    a = np.array([r.a for r in table.rows])
    alpha = np.array([r.alpha for r in table.rows])
    revolute = np.array([r.type == "revolute" for r in table.rows])
    theta = np.array([r.theta for r in table.rows]) + np.where(revolute, Q, 0.0)
    d = np.array([r.d for r in table.rows]) + np.where(revolute, 0.0, Q)
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.broadcast_to(np.cos(alpha), (N, n)), np.broadcast_to(np.sin(alpha), (N, n))
    a = np.broadcast_to(a, (N, n))
    A = np.zeros((N, n, 4, 4))
    A[..., 3, 3] = 1.0
    if table.convention == "standard":
        A[..., 0, :] = np.stack([ct, -st * ca, st * sa, a * ct], axis=-1)
        A[..., 1, :] = np.stack([st, ct * ca, -ct * sa, a * st], axis=-1)
        A[..., 2, :] = np.stack([np.zeros_like(ct), sa, ca, d], axis=-1)
    else:
        A[..., 0, :] = np.stack([ct, -st, np.zeros_like(ct), a], axis=-1)
        A[..., 1, :] = np.stack([st * ca, ct * ca, -sa, -sa * d], axis=-1)
        A[..., 2, :] = np.stack([st * sa, ct * sa, ca, ca * d], axis=-1)
    return A


def dh_transforms(table: DHTable, Q) -> np.ndarray:
    """Poses of the DH frames (N, n, 4, 4): ``T_world_frame_i = base A_1 ... A_i`` (i = 1..n).

    ``Q`` is (N, n) (or (n,) for one configuration), in row order.

    De Luca's 2R planar arm (``a1 = a2 = 1``): frame 2 at ``(c_1 + c_12, s_1 + s_12)``.

    >>> from kinematics.io import table_from_dict
    >>> row = {"type": "R", "a": 1, "alpha": 0, "d": 0, "theta": 0}
    >>> t = table_from_dict({"joints": [row, row]})
    >>> dh_transforms(t, [[np.pi / 6, np.pi / 3]])[0, :, :2, 3].round(12)
    array([[0.8660254, 0.5      ],
           [0.8660254, 1.5      ]])
    """
    A = dh_row_transforms(table, Q)
    N, n = A.shape[:2]
    out = np.empty_like(A)
    T = np.broadcast_to(table.base, (N, 4, 4))
    for i in range(n):
        T = T @ A[:, i]
        out[:, i] = T
    return out


def dh_tool_pose(table: DHTable, Q) -> np.ndarray:
    """Tool poses (N, 4, 4): ``T_world_tool = base A_1 ... A_n tool``.

    The RPR arm of the forward-kinematics example in Spong's convention (``d1 = 0.3``,
    ``d3 = 0.1``) has the closed form
    ``T3_0 = [[c1 c3, -c1 s3, s1, s1 (d2 + d3)], [s1 c3, -s1 s3, -c1, -c1 (d2 + d3)],
    [s3, c3, 0, d1]]``; at ``theta1 = 90°``, ``d2 = 0.2``, ``theta3 = 0``:

    >>> from kinematics.io import default_catalogue
    >>> from kinematics.io.dh_table import load_table
    >>> rpr = load_table(default_catalogue().entry("rpr_example").path)
    >>> dh_tool_pose(rpr, [[np.pi / 2, 0.2, 0.0]])[0].round(12) + 0.0
    array([[0. , 0. , 1. , 0.3],
           [1. , 0. , 0. , 0. ],
           [0. , 1. , 0. , 0.3],
           [0. , 0. , 0. , 1. ]])
    """
    return dh_transforms(table, Q)[:, -1] @ table.tool


class _Frame:
    """An orthonormal frame in the world at q = 0: origin ``o``, axes ``x`` and ``z``."""

    __slots__ = ("o", "x", "z")

    def __init__(self, o, x, z):
        z = np.asarray(z, float) / np.linalg.norm(z)
        x = np.asarray(x, float)
        x = x - (x @ z) * z  # exact orthogonality
        self.o, self.x, self.z = np.asarray(o, float), x / np.linalg.norm(x), z

    def matrix(self) -> np.ndarray:
        T = np.eye(4)
        T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = self.x, np.cross(self.z, self.x), self.z, self.o
        return T


def _perp(z: np.ndarray, candidates) -> np.ndarray:
    """The first candidate with a usable component perpendicular to ``z``, normalised."""
    for c in candidates:
        v = np.asarray(c, float) - (np.asarray(c, float) @ z) * z
        if np.linalg.norm(v) > _PICK_MIN_NORM:
            return v / np.linalg.norm(v)
    raise AssertionError("no perpendicular candidate")  # the world axes always give one


def _distance_tolerance(r: np.ndarray) -> float:
    """Distances below this are zero: :data:`COINCIDENT_TOLERANCE` plus the rounding of ``r``."""
    return COINCIDENT_TOLERANCE + _ROUNDING * float(np.linalg.norm(r))


def _foot(o: np.ndarray, p: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The point of the line ``(p, w)`` closest to ``o``."""
    return p + ((o - p) @ w) * w


def _common_normal(pa, wa, pb, wb):
    """Feet ``(Pa, Pb)`` of the common perpendicular of two non-parallel lines."""
    r = pb - pa
    c = wa @ wb
    denom = float(np.sum(np.cross(wa, wb) ** 2))  # sin^2 of the angle, without 1 - c^2 cancellation
    t = ((r @ wa) - c * (r @ wb)) / denom
    s = (c * (r @ wa) - (r @ wb)) / denom
    return pa + t * wa, pb + s * wb


def _next_x(prev: _Frame, p_next: np.ndarray, w_next: np.ndarray):
    """x axis and origin for the common normal from the line of ``prev`` (through
    ``prev.o`` along ``prev.z``) to the line ``(p_next, w_next)``.

    Returns ``(x, foot_on_prev_line, foot_on_next_line)``.
    """
    cross = np.cross(prev.z, w_next)
    if np.linalg.norm(cross) > PARALLEL_TOLERANCE:
        pa, pb = _common_normal(prev.o, prev.z, p_next, w_next)
        x = cross / np.linalg.norm(cross)
    else:  # parallel: the normal through prev.o
        r = p_next - prev.o
        r_perp = r - (r @ prev.z) * prev.z
        if np.linalg.norm(r_perp) <= _distance_tolerance(r):
            return prev.x, prev.o, prev.o  # coincident: keep x, keep the origin
        x, pa, pb = r_perp / np.linalg.norm(r_perp), prev.o, prev.o + r_perp
    # x's sign is free (a and alpha change sign): keep theta's offset within +-90 degrees
    if x @ prev.x < -_SIGN_EPS:
        x = -x
    return x, pa, pb


def _angle(u: np.ndarray, v: np.ndarray, axis: np.ndarray) -> float:
    """Signed angle from ``u`` to ``v`` about ``axis`` (all unit; u, v perpendicular to axis)."""
    return math.atan2(float(np.cross(u, v) @ axis), float(u @ v))


def _snap_length(v: float) -> float:
    return 0.0 if abs(v) < SNAP_TOLERANCE else float(v) + 0.0


def _snap_angle(v: float) -> float:
    k = round(v / (math.pi / 2))
    if abs(v - k * math.pi / 2) < SNAP_TOLERANCE:
        v = k * (math.pi / 2)
    if v <= -math.pi:  # keep angles in (-pi, pi]
        v += 2 * math.pi
    return float(v) + 0.0


def _chain(model: RobotModel, tip: str | None):
    if tip is None:
        leaves = model.leaf_links
        if len(leaves) != 1:
            shown = ", ".join(repr(l) for l in leaves[:8]) + (" ..." if len(leaves) > 8 else "")
            raise NoDHFormError(
                f"model {model.name!r} is a tree with {len(leaves)} leaf links ({shown}); "
                "a DH table describes one chain: choose its tip link"
            )
        tip = leaves[0]
    if tip not in model.parent_joint and tip != model.root:
        raise UnknownLinkError(f"model {model.name!r} has no link {tip!r}"
                               + did_you_mean(tip, model.links, "link names"))
    path = model.path_joints(tip)
    for j in path:
        if j.mimic is not None:
            raise NoDHFormError(
                f"joint {j.name!r} on the chain to {tip!r} mimics {j.mimic.leader!r}; "
                "a DH table has one independent variable per row"
            )
    moving = [j for j in path if j.moving]
    if not moving:
        raise NoDHFormError(f"the chain from {model.root!r} to {tip!r} has no moving joint")
    return tip, moving


def urdf_to_dh(model: RobotModel, tip: str | None = None, convention: str = "standard") -> DHTable:
    """The DH table (with base and tool) of the chain from ``model.root`` to ``tip``.

    ``base . A_1(q_1) ... A_n(q_n) . tool`` equals the URDF's ``T_root_tip(q)`` at every
    configuration, with ``q`` the chain's moving joints in chain order (the rows carry
    their names and limits; continuous joints get no limits). ``convention`` is
    ``standard`` or ``modified``.

    Raises ``NoDHFormError`` (tree without a tip, mimic joint on the chain, no moving
    joint, an ill-conditioned chain), ``UnknownLinkError`` (unknown tip), ``DHError``
    (unknown convention).
    """
    if convention not in CONVENTIONS:
        raise DHError(f"convention: {convention!r} is not one of {list(CONVENTIONS)}")
    tip, joints = _chain(model, tip)
    poe = compile_model(model)
    idx = [poe.joint_names.index(j.name) for j in joints]
    w = [np.array(poe.w[k]) for k in idx]
    # a point on each line: the joint frame's origin at q = 0
    M = poe.fk(np.zeros((1, model.dof)), [j.child for j in joints] + [tip])[0]
    p = [M[k][:3, 3] for k in range(len(joints))]
    T_tip = M[-1]
    n = len(joints)

    # frame 0: z on axis 1, origin at the world origin's foot on it, x from the world axes
    z0 = w[0]
    f0 = _Frame(_foot(np.zeros(3), p[0], z0), _perp(z0, np.eye(3)), z0)

    tip_o = T_tip[:3, 3]

    def tip_axes(prev: _Frame, line_p: np.ndarray, line_w: np.ndarray):
        """(foot of the tip on the last axis, x pointing from the axis to the tip)."""
        foot = _foot(tip_o, line_p, line_w)
        r = tip_o - foot
        if np.linalg.norm(r) > _distance_tolerance(tip_o - line_p):
            return foot, r / np.linalg.norm(r)
        return foot, _perp(line_w, [T_tip[:3, 0], T_tip[:3, 1], prev.x])

    frames: list[_Frame] = [f0]
    if convention == "standard":
        # frame k (k = 0..n-1) has z on axis k+1; its x is the normal from axis k to axis k+1
        for k in range(1, n):
            x, _, pb = _next_x(frames[-1], p[k], w[k])
            frames.append(_Frame(pb, x, w[k]))
        prev = frames[-1]
        foot, x = tip_axes(prev, prev.o, prev.z)
        origin = foot + (tip_o - foot) @ x * x  # the tip itself when it is off the last axis
        # x_n is perpendicular to z_{n-1}; z_n follows the tip's z as closely as possible
        zt = T_tip[:3, 2] - (T_tip[:3, 2] @ x) * x
        frames.append(_Frame(origin, x, zt if np.linalg.norm(zt) > _PICK_MIN_NORM else prev.z))
        rows = []
        for i, j in enumerate(joints, start=1):
            f, g = frames[i - 1], frames[i]
            v = g.o - f.o
            rows.append(_row(j, a=v @ g.x, alpha=_angle(f.z, g.z, g.x), d=v @ f.z, theta=_angle(f.x, g.x, f.z)))
    else:
        # frame k (k = 1..n) has z on axis k; its x is the normal from axis k to axis k+1
        for k in range(1, n):
            prev = frames[-1]
            on_line = _Frame(_foot(prev.o, p[k - 1], w[k - 1]), prev.x, w[k - 1])
            x, pa, _ = _next_x(on_line, p[k], w[k])
            frames.append(_Frame(pa, x, w[k - 1]))
        prev = frames[-1]
        foot, x = tip_axes(prev, p[n - 1], w[n - 1])
        frames.append(_Frame(foot, x, w[n - 1]))
        rows = []
        for i, j in enumerate(joints, start=1):
            f, g = frames[i - 1], frames[i]
            v = g.o - f.o
            rows.append(_row(j, a=v @ f.x, alpha=_angle(f.z, g.z, f.x), d=v @ g.z, theta=_angle(f.x, g.x, g.z)))
    base = frames[0].matrix()
    tool = np.linalg.inv(frames[-1].matrix()) @ T_tip
    tool[3] = (0.0, 0.0, 0.0, 1.0)
    table = DHTable(
        name=model.name,
        convention=convention,
        rows=tuple(rows),
        base=frozen_array(_clean(base)),
        tool=frozen_array(_clean(tool)),
        angles="radians",
    )
    _verify(model, table, tip)
    return table


def _clean(T: np.ndarray) -> np.ndarray:
    T = np.where(np.abs(T) < SNAP_TOLERANCE, 0.0, T)
    T[np.abs(np.abs(T) - 1.0) < SNAP_TOLERANCE] = np.sign(T[np.abs(np.abs(T) - 1.0) < SNAP_TOLERANCE])
    return T + 0.0


def _row(joint, a: float, alpha: float, d: float, theta: float) -> DHRow:
    jtype = "prismatic" if joint.type == "prismatic" else "revolute"
    if max(abs(a), abs(d)) > MAX_ABS_COORDINATE:
        raise NoDHFormError(
            f"joint {joint.name!r}: the common normal of nearly parallel joint axes lies "
            f"{max(abs(a), abs(d)):.3g} m away (beyond {MAX_ABS_COORDINATE:g} m): no usable DH form"
        )
    limits = None
    if joint.type in ("revolute", "prismatic") and joint.limits is not None:
        limits = (float(joint.limits.lower), float(joint.limits.upper))
    return DHRow(
        type=jtype,
        a=_snap_length(a),
        alpha=_snap_angle(alpha),
        d=_snap_length(d),
        theta=_snap_angle(theta),
        name=joint.name,
        limits=limits,
    )


def dh_deviation(model: RobotModel, table: DHTable, tip: str, Q: np.ndarray) -> tuple[float, float]:
    """Largest deviation (position in metres, rotation entries) of the table's tool pose from
    the model's FK of ``tip`` over model configurations ``Q`` (N, dof)."""
    Q_chain = Q[:, [model.q_index[name] for name in table.joint_names]]
    diff = dh_tool_pose(table, Q_chain) - compile_model(model).fk(Q, [tip])[:, 0]
    return float(np.max(np.abs(diff[:, :3, 3]))), float(np.max(np.abs(diff[:, :3, :3])))


def _verify(model: RobotModel, table: DHTable, tip: str) -> None:
    rng = np.random.default_rng(0)
    Q = model.sample_configurations(VERIFY_SAMPLES, rng, continuous_range=math.pi)
    err = max(dh_deviation(model, table, tip, np.vstack([np.zeros((1, model.dof)), Q])))
    if not err <= AGREEMENT_TOLERANCE:
        raise NoDHFormError(
            f"the DH table of the chain to {tip!r} deviates from the URDF by {err:.3g} "
            f"(tolerance {AGREEMENT_TOLERANCE:g}); nearly parallel joint axes make the DH form ill-conditioned"
        )
