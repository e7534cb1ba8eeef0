"""Product-of-exponentials forward kinematics and Jacobians, vectorised over batches.

``PoEModel`` is the compiled form of a :class:`~kinematics.model.RobotModel`: at q = 0 it
reads, for every moving joint ``j`` (mimic joints included), the space screw
``S_j = (w_j, v_j)`` with ``v_j = -w_j x r_j`` (revolute, continuous) or ``(0, axis_j)``
(prismatic), and for every link ``L`` its home pose ``M_L = T_world_L(0)``. Then

    T_world_L(q) = exp([S_1] q_1) ... exp([S_k] q_k) M_L

over the moving joints on the path from the root to ``L``. In a tree the prefix products
``P_j = P_parent(j) exp([S_j] q_j)`` are shared by every link below joint ``j``, so each
exponential and each product is computed once per configuration.

``fk`` and ``jacobian`` run the compiled kernels (:mod:`kinematics.engine.compiled`, with
the constants of :mod:`kinematics.engine.plans`). The straightforward implementation --
stacked ``(N, 4, 4)`` products, exactly the formulas above -- stays here as
``fk_reference`` and ``jacobian_reference``, the definition the kernels are tested against
(to 1e-12, every catalogue model).

Jacobians are 6 x dof, **linear rows first**, in one of three references (Pinocchio's
meaning): ``world``, ``local``, ``local_world_aligned``.

The 3R spatial open chain of Modern Robotics (Lynch & Park, Example 4.2), with
``L1 = 0.6``, ``L2 = 0.4``: ``S_1 = (0,0,1; 0,0,0)``, ``S_2 = (0,-1,0; 0,0,-L1)``,
``S_3 = (1,0,0; 0,-L2,0)`` and ``M = [[0,0,1,L1],[0,1,0,0],[-1,0,0,-L2]]``. Turning joint 2
by π/2 swings the tool from ``(L1, 0, -L2)`` to ``(L1 + L2, 0, 0)``:

>>> from kinematics.spatial.transforms import exp_screws
>>> w = np.array([[0.0, 0, 1], [0, -1, 0], [1, 0, 0]])
>>> r = np.array([[0.0, 0, 0], [0.6, 0, 0], [0, 0, -0.4]])  # a point on each axis
>>> M = np.array([[0.0, 0, 1, 0.6], [0, 1, 0, 0], [-1, 0, 0, -0.4], [0, 0, 0, 1]])
>>> E = exp_screws(w, r, np.array([True, True, True]), np.array([0.0, np.pi / 2, 0.0]))
>>> (E[0] @ E[1] @ E[2] @ M)[:3, 3].round(12) + 0.0
array([1., 0., 0.])
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Sequence

import numpy as np

from ..errors import KinematicsError
from ..model.derived import PerModel
from ..model.robot import RobotModel
from ..spatial.reference import Reference, parse_reference
from ..spatial.transforms import as_tool, exp_screws
from .compiled import PRISMATIC, REF_LOCAL, REF_LOCAL_WORLD_ALIGNED, REF_WORLD, REVOLUTE
from .plans import Kernel
from .rooted import FloatingRootModel, floating_root_joint, subtree_model
from .tree import TreeModel


@dataclass(frozen=True, eq=False)
class PoEModel:
    """Compiled PoE parameters of a model (immutable; safe to share between threads).

    Attributes (n = number of moving joints including mimic joints, in topological order):
        model: the source model.
        joint_names: names of the n moving joints.
        kind: (n,) REVOLUTE or PRISMATIC.
        w: (n, 3) unit axes in the world frame at q = 0 (prismatic: the direction).
        r: (n, 3) a point on each revolute axis (prismatic: zeros).
        S: (n, 6) space screws ``(w, v)``, angular first (Modern Robotics order).
        parent: (n,) index of the nearest moving ancestor joint, -1 at the root.
        q_index: (n,) column of q that drives the joint (the leader's for a mimic).
        multiplier, offset: (n,) joint value = multiplier * q[q_index] + offset.
        link_names: every link, document order.
        M: (L, 4, 4) home poses.
        link_joint: (L,) index of the last moving joint on the link's path, -1 if none.
    """

    model: RobotModel
    joint_names: tuple[str, ...]
    kind: np.ndarray
    w: np.ndarray
    r: np.ndarray
    S: np.ndarray
    parent: np.ndarray
    q_index: np.ndarray
    multiplier: np.ndarray
    offset: np.ndarray
    link_names: tuple[str, ...]
    M: np.ndarray
    link_joint: np.ndarray

    @property
    def dof(self) -> int:
        return self.model.dof

    @classmethod
    def from_model(cls, model: RobotModel) -> "PoEModel":
        T_home: dict[str, np.ndarray] = {model.root: np.eye(4)}
        last_moving: dict[str, int] = {model.root: -1}
        names, kind, w, r, parent, qi, mult, off = [], [], [], [], [], [], [], []
        for link in model.topological_links():
            for j in model.children[link]:
                T_joint = T_home[link] @ j.origin  # T_world_jointframe at q = 0
                T_home[j.child] = T_joint
                if not j.moving:
                    last_moving[j.child] = last_moving[link]
                    continue
                axis_world = T_joint[:3, :3] @ j.axis
                names.append(j.name)
                kind.append(PRISMATIC if j.type == "prismatic" else REVOLUTE)
                w.append(axis_world)
                r.append(T_joint[:3, 3] if j.type != "prismatic" else np.zeros(3))
                parent.append(last_moving[link])
                resolved = model.resolve_mimic(j)
                if resolved is None:
                    qi.append(model.q_index[j.name]); mult.append(1.0); off.append(0.0)
                else:
                    leader, m, o = resolved
                    qi.append(model.q_index[leader]); mult.append(m); off.append(o)
                last_moving[j.child] = len(names) - 1
        n = len(names)
        w_a = np.array(w, dtype=float).reshape(n, 3)
        r_a = np.array(r, dtype=float).reshape(n, 3)
        kind_a = np.array(kind, dtype=np.int8)
        S = np.zeros((n, 6))
        rev = kind_a == REVOLUTE
        S[rev, :3] = w_a[rev]
        S[rev, 3:] = -np.cross(w_a[rev], r_a[rev])
        S[~rev, 3:] = w_a[~rev]
        arrays = dict(
            kind=kind_a, w=w_a, r=r_a, S=S,
            parent=np.array(parent, dtype=np.intp), q_index=np.array(qi, dtype=np.intp),
            multiplier=np.array(mult, dtype=float), offset=np.array(off, dtype=float),
            M=np.array([T_home[l] for l in model.links]).reshape(len(model.links), 4, 4),
            link_joint=np.array([last_moving[l] for l in model.links], dtype=np.intp),
        )
        for a in arrays.values():
            a.setflags(write=False)
        return cls(model=model, joint_names=tuple(names), link_names=model.links, **arrays)

    # ------------------------------------------------------------------ helpers
    def link_indices(self, links: Sequence[str] | None) -> np.ndarray:
        """Indices of ``links`` (None: every link); unknown names raise :class:`UnknownLinkError`."""
        return self.model.link_indices(links)

    @property
    def model_link_index(self) -> dict[str, int]:
        """Index of each link name in ``link_names``."""
        return self.model.link_index

    def joint_values(self, Q: np.ndarray) -> np.ndarray:
        """Values (N, n) of every moving joint (mimic joints included) from q (N, dof)."""
        return Q[:, self.q_index] * self.multiplier + self.offset

    def joint_exponentials(self, theta: np.ndarray) -> np.ndarray:
        """``exp([S_j] theta_j)`` for every moving joint: (N, n, 4, 4)."""
        return exp_screws(self.w, self.r, self.kind == REVOLUTE, theta)

    def prefix_products(self, Q: np.ndarray) -> np.ndarray:
        """``P_j = exp([S_1]q_1) ... exp([S_j]q_j)`` along each joint's path: (N, n, 4, 4)."""
        E = self.joint_exponentials(self.joint_values(Q))
        P = np.empty_like(E)
        for j in range(E.shape[1]):  # loop over joints, never over configurations
            p = self.parent[j]
            P[:, j] = E[:, j] if p < 0 else P[:, p] @ E[:, j]
        return P

    # ------------------------------------------------------------------ fast kernels
    @cached_property
    def kernel(self) -> Kernel:
        """What the compiled kernels read of this model (:class:`~kinematics.engine.plans.Kernel`)."""
        return Kernel(self)

    def fk(self, Q: np.ndarray, links: Sequence[str] | None = None, out: np.ndarray | None = None,
           tool: np.ndarray | None = None) -> np.ndarray:
        """Poses ``T_world_link`` of ``links`` (default all) for a batch q (N, dof): (N, L, 4, 4).

        ``out`` (optional, float64 C-contiguous of that shape) receives the result, so a caller
        can reuse one buffer across calls. Same result as :meth:`fk_reference` (to ~1e-15).
        ``tool``: ``T_link_tool`` (4, 4); the poses are then ``T_world_link @ T_link_tool``.
        """
        if type(Q) is not np.ndarray or Q.dtype != np.float64:
            Q = np.asarray(Q, dtype=float)
        if Q.ndim != 2 or Q.shape[1] != self.dof:
            raise KinematicsError(f"q must have shape (N, {self.dof}), got {Q.shape}")
        kernel = self.kernel
        plan = kernel.named_plan(links)  # names resolved once per list of names (a cache of the kernel)
        if out is not None:
            n_out = plan.lj.shape[0]
            if out.shape != (Q.shape[0], n_out, 4, 4) or out.dtype != np.float64 or not out.flags.c_contiguous:
                raise KinematicsError(f"out must be a C-contiguous float64 array of shape {(Q.shape[0], n_out, 4, 4)}")
        return kernel.fk(Q, out=out, tool=None if tool is None else as_tool(tool), plan=plan)

    def jacobian(self, Q: np.ndarray, link: str, reference: str = Reference.WORLD,
                 tool: np.ndarray | None = None) -> np.ndarray:
        """Jacobian (N, 6, dof) of ``link``, linear rows first, in ``reference``.

        Same result as :meth:`jacobian_reference` (to ~1e-15). ``tool``: ``T_link_tool`` (4, 4):
        the Jacobian of the frame at that offset from the link (Pinocchio's frame semantics:
        ``local_world_aligned`` and ``world`` rows move their reference point with it, ``local``
        also turns into its axes).
        """
        reference = parse_reference(reference)
        li = self.model.link_index.get(link) if type(link) is str else None
        if li is None:  # unknown (named in the error) or not a name
            li = int(self.link_indices([link])[0])
        if type(Q) is not np.ndarray or Q.dtype != np.float64:
            Q = np.asarray(Q, dtype=float)
        if Q.ndim != 2 or Q.shape[1] != self.dof:
            raise KinematicsError(f"q must have shape (N, {self.dof}), got {Q.shape}")
        return self.kernel.jacobian(Q, li, reference, tool=None if tool is None else as_tool(tool))

    def velocity(self, Q: np.ndarray, Qd: np.ndarray, links: Sequence[str] | None = None,
                 tool: np.ndarray | None = None) -> dict[Reference, np.ndarray]:
        """Twists of ``links`` (default all) for joint values and velocities ``Q``, ``Qd`` (N, dof),
        one pass down the tree (:mod:`kinematics.engine.velocity`): per reference an (N, L, 6)
        array, linear part first. ``local_world_aligned`` holds the velocity of the link origin and
        the angular velocity in world axes. Equal to ``J(q) qdot`` of :meth:`jacobian`.
        ``tool``: ``T_link_tool`` (4, 4), the frame whose velocity it is (applied to every link).
        """
        Q = np.asarray(Q, dtype=float)
        Qd = np.asarray(Qd, dtype=float)
        if Q.ndim != 2 or Q.shape[1] != self.dof or Qd.shape != Q.shape:
            raise KinematicsError(f"q and qdot must have shape (N, {self.dof}), got {Q.shape} and {Qd.shape}")
        idx = None if links is None else self.link_indices(links)
        V = self.kernel.velocity(Q, Qd, idx, tool=as_tool(tool))
        return {ref: V[code] for ref, code in _VELOCITY_CODES.items()}

    # ------------------------------------------------------------------ FK (reference)
    def fk_reference(self, Q: np.ndarray, links: Sequence[str] | None = None) -> np.ndarray:
        """Reference FK: poses of ``links`` (default all) for q (N, dof) by stacked 4x4 products."""
        idx = self.link_indices(links)
        Q = np.asarray(Q, dtype=float)
        P = self.prefix_products(Q)
        out = np.empty((Q.shape[0], len(idx), 4, 4))
        for k, li in enumerate(idx):
            j = self.link_joint[li]
            out[:, k] = self.M[li] if j < 0 else P[:, j] @ self.M[li]
        return out

    # ------------------------------------------------------------------ Jacobians (reference)
    def path_mask(self, link_index: int) -> np.ndarray:
        """Boolean (n,) mask of the moving joints on the path from the root to the link."""
        mask = np.zeros(len(self.joint_names), dtype=bool)
        j = self.link_joint[link_index]
        while j >= 0:
            mask[j] = True
            j = self.parent[j]
        return mask

    def jacobian_reference(self, Q: np.ndarray, link: str, reference: str = Reference.WORLD) -> np.ndarray:
        """Reference Jacobian (N, 6, dof) of ``link``, linear rows first, in ``reference``."""
        reference = parse_reference(reference)
        li = int(self.link_indices([link])[0])
        Q = np.asarray(Q, dtype=float)
        N = Q.shape[0]
        P = self.prefix_products(Q)
        jl = self.link_joint[li]
        T_L = np.broadcast_to(self.M[li], (N, 4, 4)) if jl < 0 else P[:, jl] @ self.M[li]
        J = np.zeros((N, 6, self.dof))
        for j in np.flatnonzero(self.path_mask(li)):
            p = self.parent[j]
            if p < 0:
                ang = np.broadcast_to(self.S[j, :3], (N, 3))
                lin = np.broadcast_to(self.S[j, 3:], (N, 3))
            else:
                R = P[:, p, :3, :3]
                t = P[:, p, :3, 3]
                ang = R @ self.S[j, :3]
                lin = R @ self.S[j, 3:] + np.cross(t, ang)
            J[:, :3, self.q_index[j]] += self.multiplier[j] * lin
            J[:, 3:, self.q_index[j]] += self.multiplier[j] * ang
        if reference == Reference.WORLD:
            return J
        p_L = T_L[:, :3, 3]
        # velocity of the link origin: v_o + w x p_L
        J[:, :3, :] += np.cross(J[:, 3:, :], p_L[:, :, None], axisa=1, axisb=1, axisc=1)
        if reference == Reference.LOCAL_WORLD_ALIGNED:
            return J
        Rt = np.swapaxes(T_L[:, :3, :3], 1, 2)
        return np.concatenate([Rt @ J[:, :3, :], Rt @ J[:, 3:, :]], axis=1)


_VELOCITY_CODES = {Reference.WORLD: REF_WORLD, Reference.LOCAL: REF_LOCAL,
                   Reference.LOCAL_WORLD_ALIGNED: REF_LOCAL_WORLD_ALIGNED}




def _compile(model: RobotModel) -> "PoEModel | TreeModel":
    if not model.multi_dof:
        return PoEModel.from_model(model)
    joint = floating_root_joint(model)
    if joint is None:
        return TreeModel(model)
    sub = subtree_model(model, joint)
    # floating_base: the fixed-base model's own compiled form (through the cache, shared); else its own
    return FloatingRootModel(model, joint, _compiled(sub) if sub is model.base_model else PoEModel.from_model(sub))


_compiled = PerModel(_compile)


def compile_model(model: RobotModel) -> "PoEModel | TreeModel":
    """The compiled form of ``model``, built once per model object (thread-safe) and kept as long
    as the model lives: the PoE kernels' :class:`PoEModel` for a model of one-dof joints; for a
    model whose only multi-dof joint is a floating joint with only fixed joints outside its sub-tree
    (hanging from the root link: ``floating_base``, an MJCF freejoint of a top-level body) the same
    kernels below that joint,
    :class:`~kinematics.engine.rooted.FloatingRootModel`; for any other model with a floating or planar
    joint the numpy tree walk :class:`~kinematics.engine.tree.TreeModel`. The last two have the same
    ``fk``, ``jacobian``, ``velocity``, ``frames``, ``integrate`` and ``link_indices``."""
    return _compiled(model)


def require_one_dof(model: RobotModel, what: str) -> PoEModel:
    """The :class:`PoEModel` of a model of one-dof joints; for a model with floating or planar joints,
    :class:`~kinematics.errors.UnsupportedJointError` saying that ``what`` is not available for it."""
    if model.multi_dof:
        from ..errors import UnsupportedJointError

        kinds = sorted({j.type for j in model.joints if j.type in ("floating", "planar")})
        raise UnsupportedJointError(f"{what} is not available for models with {' or '.join(kinds)} joints "
                                    f"(model {model.name!r}); FK, Jacobians, velocities and IK are")
    return _compiled(model)


def compiled_counts() -> tuple[int, int]:
    """``(compiled, cached)``: the models this process has compiled so far, and the compiled forms it
    holds now (one per live model)."""
    return _compiled.built, len(_compiled)
