"""The engine of models with floating or planar joints: a tree walk vectorised with numpy.

The compiled PoE kernels (:mod:`kinematics.engine.poe`) treat one-dof screws only; a model with a
floating or planar joint anywhere in its tree is compiled to a :class:`TreeModel` instead
(:func:`kinematics.engine.poe.compile_model` picks it), with the same methods (``fk``,
``jacobian``, ``velocity``, ``link_indices``) -- except the common case of a model whose only
multi-dof joint is a floating joint at the root (``floating_base``, MJCF freejoints), which gets the
compiled kernels below that joint (:class:`kinematics.engine.rooted.FloatingRootModel`, a subclass
that keeps this walk's ``integrate`` and equals it to ~1e-15). Per configuration batch, down the tree:

    T_world_child = T_world_parent @ origin_j @ X_j(q_j)

with the joint motion ``X_j`` in Pinocchio's conventions (``docs/design.md``, "q"):

- revolute / continuous: a rotation by ``θ`` about the axis; prismatic: ``θ`` along it
  (``θ = multiplier q[leader] + offset`` for a mimic joint);
- floating: ``(R(qx, qy, qz, qw), (x, y, z))`` (Pinocchio's JointModelFreeFlyer);
- planar: ``(Rz(θ), (x, y, 0))`` from ``(x, y, cos θ, sin θ)`` (JointModelPlanar).

Velocities: each joint's velocity ``v_j`` is a twist of its child frame in that frame (linear
part first), ``S_j v_j`` with the motion subspace ``S_j``: revolute ``(0; axis)``, prismatic
``(axis; 0)``, floating the 6x6 identity, planar the columns ``vx, vy, ωz``. The space
(``world``) Jacobian's columns are ``Ad(T_world_child) S_j`` (``ω = R s_ω``,
``v = R s_v + p x ω``), and a link's world twist is the sum of the columns on its path times
``v``. ``local_world_aligned`` moves the reference point to the link (or tool) origin and
``local`` also turns into its axes -- as for the PoE engine and Pinocchio.

``integrate`` is ``q ⊕ v`` on the configuration manifold (Pinocchio's ``integrate``): floating
``M exp6(v)`` (a unit quaternion again), planar the same on SE(2), angles and displacements
added.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..errors import KinematicsError
from ..model.robot import RobotModel
from ..spatial.lie import matrix_to_quaternion_xyzw, quaternion_xyzw_to_matrix, se3_exp
from ..spatial.reference import Reference, parse_reference
from ..spatial.rotations import skew
from ..spatial.transforms import as_tool


def _motion_subspace(kind: str, axis: np.ndarray) -> np.ndarray:
    """``S`` (6, k) of a joint in its child frame, linear rows first."""
    if kind in ("revolute", "continuous"):
        return np.concatenate([np.zeros(3), axis])[:, None]
    if kind == "prismatic":
        return np.concatenate([axis, np.zeros(3)])[:, None]
    if kind == "floating":
        return np.eye(6)
    if kind == "planar":
        S = np.zeros((6, 3))
        S[0, 0] = S[1, 1] = S[5, 2] = 1.0
        return S
    return np.zeros((6, 0))


@dataclass(frozen=True, eq=False)
class Step:
    """One joint of the walk: parent and child link indices, ``origin`` (4, 4), the joint type and
    axis, its first q and v entries (a mimic joint's leader's), multiplier and offset, ``S`` (6, k)."""

    name: str
    parent: int
    child: int
    origin: np.ndarray
    type: str
    axis: np.ndarray
    q: int
    v: int
    multiplier: float
    offset: float
    S: np.ndarray

    @property
    def moving(self) -> bool:
        return self.type != "fixed"


class TreeModel:
    """The numpy engine of a model with multi-dof joints (immutable; safe to share between threads)."""

    def __init__(self, model: RobotModel):
        self.model = model
        self.link_names = model.links
        index = {name: i for i, name in enumerate(model.links)}
        steps = []
        for link in model.topological_links():
            for j in model.children[link]:
                q = v = -1
                mult, off = 1.0, 0.0
                if j.moving:
                    resolved = model.resolve_mimic(j)
                    leader = j.name if resolved is None else resolved[0]
                    if resolved is not None:
                        mult, off = resolved[1], resolved[2]
                    slot = model.slot[leader]
                    q, v = slot.q_start, slot.v_start
                axis = np.asarray(j.axis, dtype=float)
                S = _motion_subspace(j.type, axis)
                for a in (axis, S):
                    a.setflags(write=False)
                steps.append(Step(j.name, index[link], index[j.child], np.asarray(j.origin, dtype=float), j.type,
                                  axis, q, v, mult, off, S))
        self.steps: tuple[Step, ...] = tuple(steps)
        self.root = index[model.root]
        by_child = {s.child: s for s in self.steps}
        paths = []
        for li in range(len(model.links)):
            path, link = [], li
            while link in by_child:
                path.append(by_child[link])
                link = by_child[link].parent
            paths.append(tuple(s for s in reversed(path) if s.moving))
        #: per link, the moving joints from the root to it, in order
        self.paths: tuple[tuple[Step, ...], ...] = tuple(paths)

    # ------------------------------------------------------------------ helpers
    @property
    def dof(self) -> int:
        """Columns of a Jacobian: ``nv``."""
        return self.model.nv

    @property
    def nq(self) -> int:
        return self.model.nq

    @property
    def model_link_index(self) -> dict[str, int]:
        return self.model.link_index

    def link_indices(self, links: Sequence[str] | None) -> np.ndarray:
        """Indices of ``links`` (None: every link); unknown names raise :class:`UnknownLinkError`."""
        return self.model.link_indices(links)

    def _check_q(self, Q) -> np.ndarray:
        Q = np.asarray(Q, dtype=float)
        if Q.ndim != 2 or Q.shape[1] != self.nq:
            raise KinematicsError(f"q must have shape (N, {self.nq}), got {Q.shape}")
        return Q

    # ------------------------------------------------------------------ the walk
    def motion(self, step: Step, Q: np.ndarray) -> np.ndarray:
        """``X_j(q)`` (N, 4, 4) of a moving joint."""
        N = Q.shape[0]
        X = np.zeros((N, 4, 4))
        X[:, 3, 3] = 1.0
        t = step.type
        if t in ("revolute", "continuous"):
            theta = step.multiplier * Q[:, step.q] + step.offset
            K = skew(step.axis)
            X[:, :3, :3] = np.eye(3) + np.sin(theta)[:, None, None] * K + (1 - np.cos(theta))[:, None, None] * (K @ K)
        elif t == "prismatic":
            theta = step.multiplier * Q[:, step.q] + step.offset
            X[:, :3, :3] = np.eye(3)
            X[:, :3, 3] = theta[:, None] * step.axis
        elif t == "floating":
            X[:] = floating_pose(Q[:, step.q:step.q + 7])
        elif t == "planar":
            c, s = Q[:, step.q + 2], Q[:, step.q + 3]
            X[:, 0, 0], X[:, 0, 1], X[:, 1, 0], X[:, 1, 1] = c, -s, s, c
            X[:, 2, 2] = 1.0
            X[:, :2, 3] = Q[:, step.q:step.q + 2]
        else:  # pragma: no cover - fixed joints have no motion
            X[:, :3, :3] = np.eye(3)
        return X

    def frames(self, Q: np.ndarray) -> np.ndarray:
        """``T_world_link`` (N, L, 4, 4) of every link (the root frame is the world)."""
        Q = self._check_q(Q)
        N = Q.shape[0]
        T = np.empty((N, len(self.link_names), 4, 4))
        T[:, self.root] = np.eye(4)
        for st in self.steps:
            A = T[:, st.parent] @ st.origin
            T[:, st.child] = A @ self.motion(st, Q) if st.moving else A
        return T

    def fk(self, Q: np.ndarray, links: Sequence[str] | None = None, out: np.ndarray | None = None,
           tool: np.ndarray | None = None) -> np.ndarray:
        """Poses ``T_world_link`` (N, L, 4, 4) of ``links`` (default all) for q (N, nq); ``tool``:
        ``T_link_tool``, the poses are then ``T_world_link @ T_link_tool``."""
        idx = self.link_indices(links)
        T = self.frames(Q)[:, idx]
        if tool is not None:
            T = T @ as_tool(tool)
        if out is not None:
            if out.shape != T.shape or out.dtype != np.float64:
                raise KinematicsError(f"out must be a float64 array of shape {T.shape}")
            out[...] = T
            return out
        return np.ascontiguousarray(T)

    def world_columns(self, step: Step, T_child: np.ndarray) -> np.ndarray:
        """``Ad(T_world_child) S_j`` (N, 6, k): the joint's space-Jacobian columns, linear rows first."""
        R, p = T_child[:, :3, :3], T_child[:, :3, 3]
        ang = R @ step.S[3:]
        lin = R @ step.S[:3] + np.cross(p[:, :, None], ang, axisa=1, axisb=1, axisc=1)
        return np.concatenate([lin, ang], axis=1)

    def _space_jacobian(self, T: np.ndarray, li: int) -> np.ndarray:
        N = T.shape[0]
        J = np.zeros((N, 6, self.dof))
        for st in self.paths[li]:
            cols = self.world_columns(st, T[:, st.child])
            k = cols.shape[2]
            J[:, :, st.v:st.v + k] += st.multiplier * cols if k == 1 else cols
        return J

    def jacobian(self, Q: np.ndarray, link: str, reference: str = Reference.WORLD,
                 tool: np.ndarray | None = None, frames: np.ndarray | None = None) -> np.ndarray:
        """Jacobian (N, 6, nv) of ``link``, linear rows first, in ``reference`` (``tool``: of the frame at
        that offset, Pinocchio's frame semantics). ``frames``: the walk's poses of ``Q`` if at hand."""
        reference = parse_reference(reference)
        li = int(self.link_indices([link])[0])
        T = self.frames(Q) if frames is None else frames
        J = self._space_jacobian(T, li)
        if reference == Reference.WORLD:
            return J
        F = T[:, li] if tool is None else T[:, li] @ as_tool(tool)
        return _from_world(J, F, reference)

    def velocity(self, Q: np.ndarray, Qd: np.ndarray, links: Sequence[str] | None = None,
                 tool: np.ndarray | None = None) -> dict[Reference, np.ndarray]:
        """Twists ``{reference: (N, L, 6)}`` (linear first) of ``links`` (default all) for q (N, nq) and
        velocities (N, nv): the world twist of each link summed down the tree, then moved to the link
        (or tool) origin and axes. Equal to ``J(q) v`` of :meth:`jacobian`."""
        Q = self._check_q(Q)
        Qd = np.asarray(Qd, dtype=float)
        if Qd.shape != (Q.shape[0], self.dof):
            raise KinematicsError(f"qdot must have shape ({Q.shape[0]}, {self.dof}), got {Qd.shape}")
        idx = self.link_indices(links)
        T = self.frames(Q)
        N = Q.shape[0]
        Vw = np.zeros((N, len(self.link_names), 6))
        for st in self.steps:
            Vw[:, st.child] = Vw[:, st.parent]
            if st.moving:
                cols = self.world_columns(st, T[:, st.child])
                k = cols.shape[2]
                vj = Qd[:, st.v:st.v + k] * (st.multiplier if k == 1 else 1.0)
                Vw[:, st.child] += (cols @ vj[:, :, None])[:, :, 0]
        F = T[:, idx] if tool is None else T[:, idx] @ as_tool(tool)
        return twists_at(np.ascontiguousarray(Vw[:, idx]), F)

    # ------------------------------------------------------------------ the configuration manifold
    def integrate(self, Q: np.ndarray, V: np.ndarray) -> np.ndarray:
        """``q ⊕ v`` (N, nq) (Pinocchio's ``integrate``): one-dof joints add, a floating joint moves by
        ``M exp6(v)`` (its twist in its own frame, linear first), a planar joint likewise on SE(2)."""
        Q = np.array(Q, dtype=float)
        V = np.asarray(V, dtype=float)
        for s in self.model.layout:
            if s.nq == 1:
                Q[:, s.q_start] += V[:, s.v_start]
            elif s.type == "floating":
                M = floating_pose(Q[:, s.q_slice]) @ se3_exp(V[:, s.v_slice])
                quat = matrix_to_quaternion_xyzw(M[:, :3, :3])
                old = Q[:, s.q_start + 3:s.q_start + 7]
                quat *= np.where(np.sum(quat * old, axis=1) < 0, -1.0, 1.0)[:, None]  # keep the sign continuous
                Q[:, s.q_start:s.q_start + 3] = M[:, :3, 3]
                Q[:, s.q_start + 3:s.q_start + 7] = quat
            else:  # planar: (vx, vy, wz) in the joint frame
                xi = np.zeros((Q.shape[0], 6))
                xi[:, 0], xi[:, 1], xi[:, 5] = V[:, s.v_start], V[:, s.v_start + 1], V[:, s.v_start + 2]
                E = se3_exp(xi)
                c, sn = Q[:, s.q_start + 2], Q[:, s.q_start + 3]
                x = Q[:, s.q_start] + c * E[:, 0, 3] - sn * E[:, 1, 3]
                y = Q[:, s.q_start + 1] + sn * E[:, 0, 3] + c * E[:, 1, 3]
                c2 = c * E[:, 0, 0] - sn * E[:, 1, 0]
                s2 = sn * E[:, 0, 0] + c * E[:, 1, 0]
                norm = np.hypot(c2, s2)
                Q[:, s.q_start], Q[:, s.q_start + 1] = x, y
                Q[:, s.q_start + 2], Q[:, s.q_start + 3] = c2 / norm, s2 / norm
        return Q


def floating_pose(q7: np.ndarray) -> np.ndarray:
    """``(R(qx, qy, qz, qw), (x, y, z))`` (N, 4, 4) of a floating joint's values (N, 7)."""
    X = np.zeros(q7.shape[:-1] + (4, 4))
    X[..., :3, :3] = quaternion_xyzw_to_matrix(q7[..., 3:7])
    X[..., :3, 3] = q7[..., :3]
    X[..., 3, 3] = 1.0
    return X


def twists_at(world: np.ndarray, F: np.ndarray) -> dict[Reference, np.ndarray]:
    """World twists (N, L, 6) (linear first) of bodies whose frames are F (N, L, 4, 4), in the three
    references: ``world`` as given, ``local_world_aligned`` (reference point moved to F's origin),
    ``local`` (also F's axes)."""
    lin = world[..., :3] + np.cross(world[..., 3:], F[..., :3, 3])
    lwa = np.concatenate([lin, world[..., 3:]], axis=-1)
    Rt = np.swapaxes(F[..., :3, :3], -1, -2)
    local = np.concatenate([(Rt @ lin[..., None])[..., 0], (Rt @ world[..., 3:, None])[..., 0]], axis=-1)
    return {Reference.WORLD: world, Reference.LOCAL: local, Reference.LOCAL_WORLD_ALIGNED: lwa}


def _from_world(J: np.ndarray, F: np.ndarray, reference: Reference) -> np.ndarray:
    """Space Jacobians (N, 6, n) re-expressed at frames F (N, 4, 4): ``local_world_aligned`` (reference
    point at F's origin) or ``local`` (also F's axes)."""
    J = J.copy()
    J[:, :3, :] += np.cross(J[:, 3:, :], F[:, :3, 3][:, :, None], axisa=1, axisb=1, axisc=1)
    if reference == Reference.LOCAL_WORLD_ALIGNED:
        return J
    Rt = np.swapaxes(F[:, :3, :3], 1, 2)
    return np.concatenate([Rt @ J[:, :3, :], Rt @ J[:, 3:, :]], axis=1)


