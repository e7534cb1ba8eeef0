"""The fast engine of models on a floating root: the compiled PoE kernels below one free-flyer joint.

A model whose only multi-dof joint is a **floating joint at the root** -- hanging from the root link
(or from a link fixed to it), every joint outside its sub-tree fixed: ``floating_base: true``
(``root_joint`` under ``universe``), an MJCF ``<freejoint>`` of a top-level body, a URDF with a
floating root joint -- is, below that joint, an ordinary model of one-dof joints. With ``B`` the pose
of the floating joint's child link ``C``,

    B = T_world_C = O · X(q_b)           (O = T_world_parent · origin, constant; X: the joint's motion
                                          from x, y, z, qx, qy, qz, qw)
    T_world_L = B · T_C_L(q_sub)          (L below C: the sub-tree's PoE product, C its root frame)
    T_world_L = constant                  (the root link and links fixed to it)

:func:`kinematics.engine.poe.compile_model` gives such a model a :class:`FloatingRootModel`: the
sub-tree's :class:`~kinematics.engine.poe.PoEModel` (for ``floating_base`` the fixed-base model itself,
``model.base_model``, whose compiled form is then shared) and kernels that start the frame products at
``B`` (:func:`kinematics.engine.compiled.fk_rooted`, :func:`~kinematics.engine.compiled.jacobian_rooted`):
one pass per chunk of configurations, every pose and Jacobian column written once, in the world frame.
The floating joint's six Jacobian columns are those of Pinocchio's JointModelFreeFlyer (its velocity is
the twist of ``C`` in ``C``'s frame, linear first): translations along ``B``'s axes and rotations about
them through ``B``'s origin, in the asked reference. The q of the sub-tree's joints are read from the
whole q through their slots (the floating joint need not come first in q), their columns written to
their velocity entries. Twists (:meth:`FloatingRootModel.velocity`): the sub-tree's compiled twists in
``C``'s frame plus the floating joint's, moved to the world by ``Ad(B)``. Results equal the numpy tree
walk's (:class:`~kinematics.engine.tree.TreeModel`, whose ``integrate`` this class inherits) to ~1e-15.

Any other model with floating or planar joints (a floating joint below a moving joint, a planar joint,
two floating joints, a moving joint off the floating one's sub-tree) keeps the
:class:`~kinematics.engine.tree.TreeModel`.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Sequence

import numpy as np

from ..errors import KinematicsError
from ..model.robot import MULTI_DOF_TYPES, Joint, RobotModel
from ..spatial.reference import Reference, parse_reference
from ..spatial.transforms import as_tool
from . import compiled
from .buffers import result_array
from .parallel import FK_MIN_ROWS, run_rows
from .plans import CHUNK_SIZE, PLAN_CACHE_SIZE, with_tool
from .tree import TreeModel, twists_at

_REFERENCE_CODES = {Reference.WORLD: compiled.REF_WORLD, Reference.LOCAL_WORLD_ALIGNED: compiled.REF_LOCAL_WORLD_ALIGNED,
                    Reference.LOCAL: compiled.REF_LOCAL}


def floating_root_joint(model: RobotModel) -> Joint | None:
    """The floating joint of a model that the fast path takes, else None: the model's only multi-dof
    joint, floating, and every joint outside its sub-tree fixed (so its parent is the root link or a
    link fixed to it, and links outside the sub-tree never move)."""
    multi = [j for j in model.joints if j.type in MULTI_DOF_TYPES]
    if len(multi) != 1 or multi[0].type != "floating":
        return None
    joint = multi[0]
    below = _subtree_links(model, joint.child)
    # every other joint outside the sub-tree fixed: the joint's parent is the root or fixed to it
    if any(j.moving and j is not joint and j.parent not in below for j in model.joints):
        return None
    return joint


def _subtree_links(model: RobotModel, top: str) -> set[str]:
    out, stack = set(), [top]
    while stack:
        link = stack.pop()
        out.add(link)
        stack.extend(j.child for j in model.children[link])
    return out


def subtree_model(model: RobotModel, joint: Joint) -> RobotModel:
    """The model of one-dof joints below the floating root ``joint`` (root: its child link): for
    ``floating_base`` the fixed-base model itself, else built from the model's links and joints."""
    below = _subtree_links(model, joint.child)
    names = tuple(n for n in model.joint_names if n != joint.name)
    base = model.base_model
    if (base is not None and base.root == joint.child and set(base.links) == below and base.joint_names == names
            and not base.multi_dof):
        return base
    return replace(model, links=tuple(l for l in model.links if l in below),
                   joints=tuple(j for j in model.joints if j.parent in below), root=joint.child, joint_names=names,
                   visuals={l: v for l, v in model.visuals.items() if l in below}, base_model=None)


class FloatingRootModel(TreeModel):
    """The compiled engine of a model on a floating root (see the module doc; immutable, thread-safe).

    Same ``fk``, ``jacobian``, ``velocity``, ``frames``, ``link_indices`` and ``integrate`` as
    :class:`TreeModel` (whose walk it keeps for reference: ``TreeModel.frames(self, Q)``).

    Attributes:
        joint: the floating joint; ``qb``, ``vb`` its first q and v entries; ``origin`` the constant
            ``T_world_parent @ joint.origin`` (4, 4).
        sub: the :class:`~kinematics.engine.poe.PoEModel` of the sub-tree below it.
    """

    def __init__(self, model: RobotModel, joint: Joint, sub):
        super().__init__(model)
        self.joint, self.sub = joint, sub
        slot = model.slot[joint.name]
        self.qb, self.vb = slot.q_start, slot.v_start
        kernel = sub.kernel
        n = kernel.n
        sm = sub.model
        # the sub-tree's q and v columns in the whole model's (sub q index k -> whole q / v index)
        self.q_of_sub = np.array([model.slot[name].q_start for name in sm.joint_names], dtype=np.intp)
        self.v_of_sub = np.array([model.slot[name].v_start for name in sm.joint_names], dtype=np.intp)
        jint = np.array(kernel._jint)
        jint[:, compiled.J_QINDEX] = self.q_of_sub[jint[:, compiled.J_QINDEX]] if n else 0
        jint[:, compiled.J_PARENT] = np.where(jint[:, compiled.J_PARENT] < 0, n, jint[:, compiled.J_PARENT])
        self._jint = jint
        self._jflt = kernel._jflt
        self._vcol = np.ascontiguousarray(self.v_of_sub[kernel._jint[:, compiled.J_QINDEX]], dtype=np.int64) \
            if n else np.zeros(0, dtype=np.int64)
        # where each link of the whole model is: its index in the sub-tree, or -1 (then a constant pose)
        sub_index = sub.model_link_index
        self._in_sub = np.array([sub_index.get(name, -1) for name in model.links], dtype=np.intp)
        constant = TreeModel.frames(self, model.neutral[None])[0]  # links outside the sub-tree do not move
        self._constant = np.ascontiguousarray(constant)
        #: ``O = T_world_parent @ origin``: the frame the joint's motion starts from
        self.origin = np.ascontiguousarray(constant[self.model_link_index[joint.parent]] @ joint.origin)
        for a in (self._jint, self._vcol, self._in_sub, self._constant, self.q_of_sub, self.v_of_sub, self.origin):
            a.setflags(write=False)
        self._plans: dict = {}
        self._plan_all = self._plan(None)
        self._jplans: dict = {}

    # ------------------------------------------------------------------ plans
    def _plan(self, link_idx: np.ndarray | None):
        """``(order, lj, D)`` of the compiled FK for the whole model's links ``link_idx`` (None: all)."""
        key = None if link_idx is None else tuple(int(i) for i in link_idx)
        plan = self._plans.get(key)
        if plan is not None:
            return plan
        idx = np.arange(len(self.link_names)) if link_idx is None else np.asarray(link_idx, dtype=np.intp)
        kernel, n = self.sub.kernel, self.sub.kernel.n
        subs = self._in_sub[idx]
        sp = kernel.plan(subs[subs >= 0])
        lj = np.full(len(idx), -1, dtype=np.int64)
        D = np.empty((len(idx), 4, 4))
        inside = np.flatnonzero(subs >= 0)
        lj[inside] = np.where(sp.lj < 0, n, sp.lj)
        D[inside] = sp.pose
        outside = np.flatnonzero(subs < 0)
        D[outside] = self._constant[idx[outside]]
        plan = (sp.order, lj, D)
        for a in plan:
            a.setflags(write=False)
        if len(self._plans) < PLAN_CACHE_SIZE:
            self._plans[key] = plan
        return plan

    def _path_plan(self, link_index: int):
        """``(path, D)`` of a link below the joint: its sub-tree joints root first and the constant
        factor of its pose (``G^-1 M``, or ``M`` when no sub-tree joint moves it)."""
        jp = self._jplans.get(link_index)
        if jp is None:
            kernel = self.sub.kernel
            si = int(self._in_sub[link_index])
            path, D = kernel.path_plan(si)
            if len(path) == 0:
                D = np.ascontiguousarray(self.sub.M[si])
                D.setflags(write=False)
            jp = (path, D)
            if len(self._jplans) < PLAN_CACHE_SIZE:
                self._jplans[link_index] = jp
        return jp

    # ------------------------------------------------------------------ FK
    def frames(self, Q: np.ndarray) -> np.ndarray:
        """``T_world_link`` (N, L, 4, 4) of every link (the compiled FK)."""
        return self.fk(Q)

    def fk(self, Q: np.ndarray, links: Sequence[str] | None = None, out: np.ndarray | None = None,
           tool: np.ndarray | None = None) -> np.ndarray:
        """Poses ``T_world_link`` (N, L, 4, 4) of ``links`` (default all) for q (N, nq); ``tool``:
        ``T_link_tool``, the poses are then ``T_world_link @ T_link_tool``."""
        Q = self._check_q(Q)
        order, lj, D = self._plan_all if links is None else self._plan(self.link_indices(links))
        N, n_out = Q.shape[0], lj.shape[0]
        target = out
        if out is not None:
            if out.shape != (N, n_out, 4, 4) or out.dtype != np.float64:
                raise KinematicsError(f"out must be a float64 array of shape {(N, n_out, 4, 4)}")
            if not out.flags.c_contiguous:
                target = None
        res = result_array((N, n_out, 4, 4)) if target is None else target
        if N:
            Q = np.ascontiguousarray(Q)
            D, out3, c = with_tool(D, as_tool(tool) if tool is not None else None), res.reshape(N, n_out, 16), max(1, min(CHUNK_SIZE, N))
            run_rows(lambda a, b: compiled.fk_rooted(Q[a:b], self._jint, self._jflt, order, lj, D, out3[a:b], c,
                                                     self.qb, self.origin), N, FK_MIN_ROWS, align=CHUNK_SIZE)
        if out is not None and target is None:
            out[...] = res
            return out
        return res

    # ------------------------------------------------------------------ Jacobians
    def jacobian(self, Q: np.ndarray, link: str, reference: str = Reference.WORLD,
                 tool: np.ndarray | None = None, frames: np.ndarray | None = None) -> np.ndarray:
        """Jacobian (N, 6, nv) of ``link``, linear rows first, in ``reference`` (``tool``: of the frame at
        that offset, Pinocchio's frame semantics). ``frames`` is accepted for the tree walk's signature
        (the compiled kernel recomputes the few frames it needs)."""
        reference = parse_reference(reference)
        li = int(self.link_indices([link])[0])
        Q = self._check_q(Q)
        N = Q.shape[0]
        if self._in_sub[li] < 0:  # the root link or a link fixed to it: nothing moves it
            if tool is not None:
                as_tool(tool)
            return np.zeros((N, 6, self.dof))
        J = result_array((N, 6, self.dof))
        path, D = self._path_plan(li)
        if tool is not None:
            D = with_tool(D, as_tool(tool))
        if N:
            Q = np.ascontiguousarray(Q)
            code, c = _REFERENCE_CODES[reference], max(1, min(CHUNK_SIZE, N))
            run_rows(lambda a, b: compiled.jacobian_rooted(Q[a:b], self._jint, self._jflt, self._vcol, path, D, code,
                                                           J[a:b], c, self.qb, self.vb, self.origin),
                     N, FK_MIN_ROWS, align=CHUNK_SIZE)
        return J

    # ------------------------------------------------------------------ twists
    def velocity(self, Q: np.ndarray, Qd: np.ndarray, links: Sequence[str] | None = None,
                 tool: np.ndarray | None = None) -> dict[Reference, np.ndarray]:
        """Twists ``{reference: (N, L, 6)}`` (linear first) of ``links`` (default all) for q (N, nq) and
        velocities (N, nv): the sub-tree's compiled twists in the frame of the joint's child ``C`` plus
        the joint's own (its twist in ``C``), moved to the world by ``Ad(B)``, then to the link (or tool)
        origin and axes. Equal to ``J(q) v`` of :meth:`jacobian`."""
        Q = self._check_q(Q)
        Qd = np.asarray(Qd, dtype=float)
        N = Q.shape[0]
        if Qd.shape != (N, self.dof):
            raise KinematicsError(f"qdot must have shape ({N}, {self.dof}), got {Qd.shape}")
        idx = self.link_indices(links)
        subs = self._in_sub[idx]
        inside = np.flatnonzero(subs >= 0)
        W = np.zeros((N, len(idx), 6))  # twists in C's frame, at C's origin
        if len(inside):
            if len(self.q_of_sub):
                Vs = self.sub.kernel.velocity(Q[:, self.q_of_sub], Qd[:, self.v_of_sub], subs[inside])
                W[:, inside] = Vs[compiled.REF_WORLD]
            W[:, inside] += Qd[:, None, self.vb:self.vb + 6]
        B = self.fk(Q, [self.joint.child])[:, 0]
        R, p = B[:, None, :3, :3], B[:, None, :3, 3]
        ang = (R @ W[..., 3:, None])[..., 0]
        lin = (R @ W[..., :3, None])[..., 0] + np.cross(p, ang)
        world = np.concatenate([lin, ang], axis=-1)
        return twists_at(world, self.fk(Q, None if links is None else list(links), tool=tool))
