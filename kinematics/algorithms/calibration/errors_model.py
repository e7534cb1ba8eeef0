"""The error model of a calibration: the nominal chain to one link, perturbed by small parameters.

The pose the measuring device sees of the marker (or tool) on ``link`` is a product of
one-parameter exponentials of fixed unit screws, each in its local frame:

    T_device_tool(q, x) = B(x_b) · Π_j [ C_j · D_j(x_j) · exp([ξ_j] (θ_j(q) + ε_j)) ] · C_tail · F(x_t)

over the moving joints ``j`` on the path from the root to ``link``:

- ``C_j``: the nominal ``T_prev_jointframe`` (the joint's URDF origin, times the origins of the
  fixed joints since the previous moving joint); ``C_tail`` the fixed joints after the last one;
- ``ξ_j``: the joint's unit screw in its own frame (revolute ``(0; a_j)``, prismatic ``(a_j; 0)``,
  linear part first), ``θ_j(q)`` its value (mimic joints: ``multiplier * q_leader + offset``);
- ``D_j = Tx(dx) Ty(dy) Tz(dz) Rz(dyaw) Ry(dpitch) Rx(droll)``: the correction of the joint's
  origin, in its frame, as URDF writes an origin (``xyz`` then ``rpy``); ``ε_j`` its zero offset;
- ``B = Tx Ty Tz Rz Ry Rx · R_0``: the device frame's pose of the root, ``T_device_root``
  (translation absolute, rotation a small correction about the device's axes of the start
  ``R_0`` found by point-set registration, so that no angle is ever near a gimbal lock);
- ``F``: the tool on the link, ``T_link_tool = Tx Ty Tz`` (a marker point, positions measured)
  or ``Tx Ty Tz Rz Ry Rx · R_tool`` (a tool frame, poses measured).

With a :class:`~.compliance.Compliance` option the joint values are ``θ_j(q) + ε_j - c_j τ_j(q)``:
``c_j`` the joint's compliance, ``τ_j(q)`` its gravity torque at the nominal geometry (a known
function of q), so its derivative is the zero offset's twist times ``-τ_j(q)``.

At ``x = 0`` (and the base and tool at identity) this is the product's own forward kinematics
(:class:`~kinematics.engine.poe.PoEModel`; the tests hold them equal). Because every factor is
the exponential of a fixed screw times a scalar, the derivative with respect to any parameter
is exact for any value of it: the spatial twist ``Ad(L_k) ξ_k``, with ``L_k`` the product up to
and including factor ``k``. For the zero offset ``ε_j`` that twist is the PoE Jacobian's column
of joint ``j`` (the world screw ``Ad(P_{j-1}) S_j``), for the origin corrections it is the same
adjoint of the six unit screws of the joint frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import UnsupportedJointError
from ...model.robot import RobotModel
from ...spatial.rotations import skew
from ...spatial.transforms import exp_screws
from .compliance import Compliance, GravityTorques

#: the six unit screws (linear part first) of a frame's x, y, z translations and z, y, x rotations,
#: in the order of an origin correction ``Tx Ty Tz Rz Ry Rx``
_UNIT = {
    "x": np.array([1.0, 0, 0, 0, 0, 0]), "y": np.array([0.0, 1, 0, 0, 0, 0]), "z": np.array([0.0, 0, 1, 0, 0, 0]),
    "yaw": np.array([0.0, 0, 0, 0, 0, 1]), "pitch": np.array([0.0, 0, 0, 0, 1, 0]), "roll": np.array([0.0, 0, 0, 1, 0, 0]),
}
ORIGIN_COMPONENTS = ("x", "y", "z", "yaw", "pitch", "roll")
_ANGLES = ("yaw", "pitch", "roll")
#: the base's rotations are about the device's axes: named rx, ry, rz
_BASE_NAMES = {"x": "x", "y": "y", "z": "z", "yaw": "rz", "pitch": "ry", "roll": "rx"}


@dataclass(frozen=True)
class Parameter:
    """One scalar of the error model: ``name`` (``shoulder_pan_joint.offset``, ``base.x``, ...),
    ``group`` (``base``, ``tool`` or the joint's name), ``component`` (``x`` ... ``roll``, ``offset``),
    ``angular`` (radians, else metres), ``joint_index`` (index on the path, -1 for base and tool)."""

    name: str
    group: str
    component: str
    angular: bool
    joint_index: int = -1


def factor_matrix(xi: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """``exp([ξ] θ)`` (N, 4, 4) of a unit screw ``ξ`` (6,), linear part first, that is a pure
    rotation ``(0; a)`` or a pure translation ``(a; 0)`` through the frame's origin, for values θ (N,).

    >>> factor_matrix(np.array([0.0, 0, 0, 0, 0, 1]), np.array([np.pi / 2]))[0, :2, :2].round(12) + 0.0
    array([[ 0., -1.],
           [ 1.,  0.]])
    """
    theta = np.asarray(theta, dtype=float)
    rotation = bool(np.any(xi[3:]))
    axis = xi[3:] if rotation else xi[:3]
    E = exp_screws(axis[None, :], np.zeros((1, 3)), np.array([rotation]), theta[:, None])
    return E[:, 0]


class ErrorModel:
    """The parameterised chain from the device to the marker or tool on ``link``.

    Args:
        model: a model of one-dof joints.
        link: the link the marker or tool is fixed to.
        measure: ``"position"`` (a marker point, 3 tool parameters) or ``"pose"`` (a tool frame, 6).
        parameters: ``"full"`` (every path joint's origin, 6, and zero offset, 1) or
            ``"joint_offsets"`` (the zero offsets only).
        base, tool: ``"estimate"`` or ``"fixed"``.
        R0: the start rotation of the device frame (3, 3); ``tool_rotation``: of the tool (3, 3).
        compliance: a :class:`~.compliance.Compliance` (a compliance ``c_j`` per chosen joint), or None.

    ``names`` lists the parameters in the order of the vector ``x``; ``x0`` holds the start
    values (the base translation and the tool point are absolute, everything else 0).
    """

    def __init__(self, model: RobotModel, link: str, measure: str = "position", parameters: str = "full",
                 base: str = "estimate", tool: str = "estimate", R0: np.ndarray | None = None,
                 t0: np.ndarray | None = None, point: np.ndarray | None = None,
                 tool_rotation: np.ndarray | None = None, compliance: Compliance | None = None):
        if model.multi_dof:
            raise UnsupportedJointError("calibration needs a model of one-dof joints (no floating or planar joint)")
        model.link_indices([link])  # UnknownLinkError names it
        self.model, self.link, self.measure = model, link, measure
        self.R0 = np.eye(3) if R0 is None else np.asarray(R0, dtype=float)
        self.tool_rotation = np.eye(3) if tool_rotation is None else np.asarray(tool_rotation, dtype=float)
        # the path, grouped: C_j (fixed origins up to and including joint j's), then the tail
        self.joints, self.C = [], []
        pending = np.eye(4)
        for j in model.path_joints(link):
            pending = pending @ j.origin
            if j.moving:
                self.joints.append(j)
                self.C.append(pending)
                pending = np.eye(4)
        self.C_tail = pending
        self.xi = [np.concatenate([np.zeros(3), j.axis]) if j.type != "prismatic" else np.concatenate([j.axis, np.zeros(3)])
                   for j in self.joints]
        self.value_map = []
        for j in self.joints:
            resolved = model.resolve_mimic(j)
            if resolved is None:
                self.value_map.append((model.q_index[j.name], 1.0, 0.0))
            else:
                leader, m, o = resolved
                self.value_map.append((model.q_index[leader], m, o))
        self.compliance = compliance
        compliant = [] if compliance is None else compliance.path_joints(model, self.joints)
        self.compliant = {k: n for n, k in enumerate(compliant)}  # path index -> column of the torques
        self.gravity_torques = GravityTorques(model, [self.joints[k] for k in compliant],
                                              compliance.gravity) if compliant else None
        params: list[Parameter] = []
        if base == "estimate":
            params += [Parameter(f"base.{_BASE_NAMES[c]}", "base", c, c in _ANGLES) for c in ORIGIN_COMPONENTS]
        for k, j in enumerate(self.joints):
            if parameters == "full":
                params += [Parameter(f"{j.name}.{c}", j.name, c, c in _ANGLES, k) for c in ORIGIN_COMPONENTS]
            params.append(Parameter(f"{j.name}.offset", j.name, "offset", j.type != "prismatic", k))
            if k in self.compliant:
                params.append(Parameter(f"{j.name}.compliance", j.name, "compliance", False, k))
        if tool == "estimate":
            comps = ("x", "y", "z") if measure == "position" else ORIGIN_COMPONENTS
            params += [Parameter(f"tool.{c}", "tool", c, c in _ANGLES) for c in comps]
        self.parameters = tuple(params)
        self.names = tuple(p.name for p in params)
        self.index = {p.name: i for i, p in enumerate(params)}
        self.angular = np.array([p.angular for p in params], dtype=bool)
        self.base_translation = np.zeros(3) if t0 is None else np.asarray(t0, dtype=float)
        self.point = np.zeros(3) if point is None else np.asarray(point, dtype=float)
        x0 = np.zeros(len(params))
        for k, c in enumerate("xyz"):
            if base == "estimate":
                x0[self.index[f"base.{c}"]] = self.base_translation[k]
            if tool == "estimate":
                x0[self.index[f"tool.{c}"]] = self.point[k]
        self.x0 = x0
        self.base_mode, self.tool_mode, self.mode = base, tool, parameters

    # ------------------------------------------------------------------ the chain
    def torques(self, Q: np.ndarray) -> np.ndarray | None:
        """The gravity torques (N, compliant joints) at Q, or None without compliance."""
        return None if self.gravity_torques is None else self.gravity_torques(Q)

    def corrections(self, Q: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """The size of each parameter change ``dx`` (p,) in metres or radians: a compliance's is the
        largest deflection it causes over the configurations Q."""
        out = np.abs(np.asarray(dx, dtype=float)).copy()
        if self.compliant:
            tau = np.abs(self.torques(Q)).max(axis=0)
            for k, n in self.compliant.items():
                out[self.index[f"{self.joints[k].name}.compliance"]] *= tau[n]
        return out

    def _factors(self, Q: np.ndarray, x: np.ndarray):
        """The chain as a list of ``(matrix (N, 4, 4) or (4, 4), screw or None, terms)``: a constant
        (screw None, no terms) or a factor ``exp([ξ] value)`` whose value moves with the parameters
        ``terms``: ``(index, weight)`` pairs, the weight None (1) or per configuration (N,) -- a
        joint factor's zero offset, and its compliance weighted by ``-τ_j(q)``."""
        out = []
        tau = self.torques(Q)

        def param_factor(xi, idx):
            return (factor_matrix(xi, np.array([x[idx]]))[0], xi, ((idx, None),))  # one value for every configuration

        # base
        if self.base_mode == "estimate":
            for c in ORIGIN_COMPONENTS:
                out.append(param_factor(_UNIT[c], self.index[f"base.{_BASE_NAMES[c]}"]))
        else:
            out.append((_translation(self.base_translation), None, ()))
        out.append((_rotation(self.R0), None, ()))
        for k, j in enumerate(self.joints):
            out.append((self.C[k], None, ()))
            if self.mode == "full":
                for c in ORIGIN_COMPONENTS:
                    out.append(param_factor(_UNIT[c], self.index[f"{j.name}.{c}"]))
            col, m, o = self.value_map[k]
            eps_idx = self.index[f"{j.name}.offset"]
            theta = m * Q[:, col] + o + x[eps_idx]
            terms = [(eps_idx, None)]
            if k in self.compliant:
                weight = -tau[:, self.compliant[k]]
                c_idx = self.index[f"{j.name}.compliance"]
                theta = theta + x[c_idx] * weight
                terms.append((c_idx, weight))
            out.append((factor_matrix(self.xi[k], theta), self.xi[k], tuple(terms)))
        out.append((self.C_tail, None, ()))
        tool_comps = ("x", "y", "z") if self.measure == "position" else ORIGIN_COMPONENTS
        if self.tool_mode == "estimate":
            for c in tool_comps:
                out.append(param_factor(_UNIT[c], self.index[f"tool.{c}"]))
        else:
            out.append((_translation(self.point), None, ()))
        if self.measure == "pose":
            out.append((_rotation(self.tool_rotation), None, ()))
        return out

    def predict(self, Q: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Poses ``T_device_tool`` (N, 4, 4) at configurations Q (N, dof) and parameters x."""
        T, _ = self._walk(Q, x, want_jacobian=False)
        return T

    def jacobian(self, Q: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Poses (N, 4, 4) and the spatial twists (N, 6, p), linear rows first, of the tool frame per
        unit change of each parameter: ``d p_tool = J[:, :3] dx`` is the velocity of the tool
        point, ``J[:, 3:] dx`` the angular velocity (both in device axes)."""
        return self._walk(Q, x, want_jacobian=True)

    def _walk(self, Q, x, want_jacobian):
        Q = np.asarray(Q, dtype=float)
        x = np.asarray(x, dtype=float)
        N = Q.shape[0]
        T = np.broadcast_to(np.eye(4), (N, 4, 4)).copy()
        cols = np.zeros((N, 6, len(x)))  # Ad(L_k) ξ_k, before moving the reference point
        for mat, xi, terms in self._factors(Q, x):
            T = T @ mat
            if want_jacobian and terms:
                R, t = T[:, :3, :3], T[:, :3, 3]
                w_s = R @ xi[3:]
                v_s = R @ xi[:3] + np.cross(t, w_s)
                for idx, weight in terms:
                    w = 1.0 if weight is None else weight[:, None]
                    cols[:, :3, idx] += v_s * w
                    cols[:, 3:, idx] += w_s * w
        if not want_jacobian:
            return T, None
        p = T[:, :3, 3]
        # the tool point's velocity: v + w x p
        cols[:, :3, :] += np.cross(cols[:, 3:, :], p[:, :, None], axisa=1, axisb=1, axisc=1)
        return T, cols

    # ------------------------------------------------------------------ read back
    def origin_correction(self, k: int, x: np.ndarray) -> np.ndarray:
        """``D_j · exp([ξ_j] ε_j)`` (4, 4): what joint ``k`` of the path's URDF origin is right-multiplied by."""
        j = self.joints[k]
        D = np.eye(4)
        if self.mode == "full":
            for c in ORIGIN_COMPONENTS:
                D = D @ factor_matrix(_UNIT[c], np.array([x[self.index[f"{j.name}.{c}"]]]))[0]
        return D @ factor_matrix(self.xi[k], np.array([x[self.index[f"{j.name}.offset"]]]))[0]

    def base_pose(self, x: np.ndarray) -> np.ndarray:
        """``T_device_root`` (4, 4) at parameters x."""
        if self.base_mode != "estimate":
            return _translation(self.base_translation) @ _rotation(self.R0)
        T = np.eye(4)
        for c in ORIGIN_COMPONENTS:
            T = T @ factor_matrix(_UNIT[c], np.array([x[self.index[f"base.{_BASE_NAMES[c]}"]]]))[0]
        return T @ _rotation(self.R0)

    def tool_pose(self, x: np.ndarray) -> np.ndarray:
        """``T_link_tool`` (4, 4) at parameters x (the marker point's translation for positions)."""
        T = np.eye(4)
        if self.tool_mode == "estimate":
            comps = ("x", "y", "z") if self.measure == "position" else ORIGIN_COMPONENTS
            for c in comps:
                T = T @ factor_matrix(_UNIT[c], np.array([x[self.index[f"tool.{c}"]]]))[0]
        else:
            T = T @ _translation(self.point)
        if self.measure == "pose":
            T = T @ _rotation(self.tool_rotation)
        return T


def _translation(p) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = p
    return T


def _rotation(R) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R
    return T


def so3_left_jacobian_inverse(phi: np.ndarray) -> np.ndarray:
    """``J_l^{-1}(φ)`` (N, 3, 3) of rotation vectors φ (N, 3): ``log(exp([δ]) exp([φ])) ≈ φ + J_l^{-1}(φ) δ``.

    >>> so3_left_jacobian_inverse(np.zeros((1, 3)))[0]
    array([[1., 0., 0.],
           [0., 1., 0.],
           [0., 0., 1.]])
    """
    phi = np.asarray(phi, dtype=float)
    theta = np.linalg.norm(phi, axis=-1)
    K = skew(phi)
    small = theta < 1e-4
    t = np.where(small, 1.0, theta)
    coeff = np.where(small, 1.0 / 12.0 + theta ** 2 / 720.0,
                     (1.0 / t ** 2) - (1.0 + np.cos(t)) / (2.0 * t * np.sin(t)))
    return np.eye(3) - 0.5 * K + coeff[:, None, None] * (K @ K)
