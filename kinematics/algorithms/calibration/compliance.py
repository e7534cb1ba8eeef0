"""Joint compliance under gravity: the non-geometric term of a calibration.

A joint driven through a compliant transmission (a harmonic drive, a belt, a long shaft) is not
where its encoder says when it holds a load: under the torque ``τ_j`` it holds it lags by
``c_j τ_j``. A robot that moves slowly between static measurements holds only gravity, so the
joint's value in the chain is

    θ_j = q_j + ε_j - c_j · τ_j(q)

with ``τ_j(q)`` the generalised gravity torque of the joint -- the torque (force, for a prismatic
joint) it must exert to hold the links beyond it still, computed from the masses and centres of
mass of the model's URDF (``<inertial>``) at the nominal geometry -- and ``c_j`` its compliance
(rad/(N m), or m/N), one parameter a joint that the calibration estimates with the rest. This
is the elasticity term of Nguyen et al. (FIGAROH, "Improving operational accuracy of a mobile
manipulator by modeling geometric and non-geometric parameters", 2024).

:class:`Compliance` is the option: which joints (default every moving joint on the path) and the
gravity vector in the model's root frame (default ``(0, 0, -9.81)``: the root upright).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...engine.poe import compile_model
from ...errors import CalibrationError
from ...io.inertials import link_inertials
from ...model.robot import Joint, RobotModel

#: standard gravity along the root frame's -z
STANDARD_GRAVITY = (0.0, 0.0, -9.81)


@dataclass(frozen=True)
class Compliance:
    """The option to estimate joint compliance under gravity (see the module).

    Attributes:
        joints: the joints given a compliance (names); None: every moving joint on the path. A joint
            whose gravity torque does not vary over the measurements (a vertical axis, a vertical
            prismatic joint) is reported unidentifiable like any other parameter.
        gravity: the gravity vector in the model's root frame, m/s^2.
    """

    joints: tuple[str, ...] | None = None
    gravity: tuple[float, float, float] = STANDARD_GRAVITY

    def __post_init__(self):
        g = np.asarray(self.gravity, dtype=float)
        if g.shape != (3,) or not np.all(np.isfinite(g)) or not np.any(g):
            raise CalibrationError("compliance: gravity must be 3 finite numbers, not all zero (m/s^2, root frame)",
                                   field="compliance")
        object.__setattr__(self, "gravity", tuple(float(v) for v in g))
        if self.joints is not None:
            if isinstance(self.joints, str) or not all(isinstance(j, str) for j in self.joints):
                raise CalibrationError("compliance: joints must be a list of joint names", field="compliance")
            object.__setattr__(self, "joints", tuple(self.joints))

    def path_joints(self, model: RobotModel, path: Sequence[Joint]) -> list[int]:
        """Indices into ``path`` (the moving joints to the calibrated link) given a compliance."""
        names = [j.name for j in path]
        if self.joints is None:
            return list(range(len(path)))
        unknown = [n for n in self.joints if n not in names]
        if unknown:
            raise CalibrationError(f"compliance: {', '.join(unknown)} is not a moving joint on the path to the link "
                                   f"(those are {', '.join(names)})", field="compliance")
        return [k for k, n in enumerate(names) if n in self.joints]


class GravityTorques:
    """``τ(Q)`` (N, len(joints)): the generalised gravity torque of each of ``joints`` at configurations Q
    (N, dof), from the masses and centres of mass in ``model``'s URDF (Pinocchio's
    ``computeGeneralizedGravity`` on the same URDF gives the same numbers)."""

    def __init__(self, model: RobotModel, joints: Sequence[Joint], gravity=STANDARD_GRAVITY):
        inertials = link_inertials(model.urdf)
        self.model, self.joints = model, list(joints)
        self.gravity = np.asarray(gravity, dtype=float)
        self.links = [name for name in model.links if inertials.get(name, (0.0,))[0] > 0]
        self.mass = np.array([inertials[n][0] for n in self.links])
        self.com = np.array([inertials[n][1] for n in self.links]).reshape(-1, 3)
        # which massive links each joint carries (its child's subtree)
        self.carried = np.zeros((len(self.joints), len(self.links)), dtype=bool)
        index = {n: i for i, n in enumerate(self.links)}
        for k, j in enumerate(self.joints):
            stack = [j.child]
            while stack:
                link = stack.pop()
                if link in index:
                    self.carried[k, index[link]] = True
                stack.extend(c.child for c in model.children[link])
        self.frames = [j.child for j in self.joints]

    def __call__(self, Q: np.ndarray) -> np.ndarray:
        Q = np.asarray(Q, dtype=float)
        out = np.zeros((len(Q), len(self.joints)))
        if not self.links or not self.joints:
            return out
        compiled = compile_model(self.model)
        T_mass = compiled.fk(Q, self.links)  # (N, L, 4, 4)
        c = np.einsum("nlij,lj->nli", T_mass[:, :, :3, :3], self.com) + T_mass[:, :, :3, 3]  # world COMs
        weight = self.mass[:, None] * self.gravity  # (L, 3): the force of gravity on each link
        T_j = compiled.fk(Q, self.frames)  # the joint frames (the child's frame is the joint's)
        for k, j in enumerate(self.joints):
            a = T_j[:, k, :3, :3] @ j.axis  # (N, 3) world axis
            carried = self.carried[k]
            if j.type == "prismatic":
                force = weight[carried].sum(axis=0)  # (3,)
                out[:, k] = -(a @ force)
            else:
                arm = c[:, carried] - T_j[:, k, None, :3, 3]  # (N, l, 3)
                moment = np.cross(arm, weight[carried][None]).sum(axis=1)  # (N, 3)
                out[:, k] = -np.einsum("ni,ni->n", a, moment)
        return out
