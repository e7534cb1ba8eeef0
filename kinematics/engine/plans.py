"""The constants and plans of the compiled PoE kernels (:mod:`kinematics.engine.compiled`).

These kernels evaluate exactly the product of :mod:`kinematics.engine.poe`,

    T_world_L(q) = exp([S_1] θ_1) ... exp([S_k] θ_k) M_L,

but arrange the arithmetic so that a batch costs little per configuration: the loops of
:mod:`kinematics.engine.compiled` (numba) run over chunks of configurations with every
intermediate in registers or cache, and write each pose or Jacobian column once. This
module precomputes what they read. The reference implementation
(``PoEModel.fk_reference``, ``PoEModel.jacobian_reference``) stays the definition;
``tests/kinematics/engine/test_kernels.py`` checks that both agree to 1e-12 on every catalogue model.

The regrouping
--------------
Each joint's screw ``S_j`` is a rotation about (or a translation along) a line. Put a
frame ``G_j`` on that line with its z axis along the axis (``G_j`` is built from ``w_j`` and
``r_j`` only). Then ``exp([S_j] θ) = G_j Z(θ) G_j^-1`` where ``Z(θ)`` is the rotation about
(revolute) or translation along (prismatic) the z axis. With the prefix products
``P_j = P_parent(j) exp([S_j] θ_j)`` and the "axis frames" ``F_j = P_j G_j``:

    F_j = F_parent(j) · (G_parent^-1 G_j) · Z(θ_j)        (F_parent = I, G_parent = I at the root)
    T_world_L = F_j · (G_j^-1 M_L)                       (j: the last moving joint above L)

Both constant factors (``CZ_j`` and ``D4_L``) are precomputed. Right-multiplying by
``Z(θ)`` only mixes the first two rotation columns of ``F_j`` with ``cos θ`` and ``sin θ``
(prismatic: adds ``θ`` times the third column to the translation), and ``F_j``'s third
column and origin are the joint axis and a point on it in world coordinates, which is all
the Jacobian needs.

FK results come from :func:`kinematics.engine.buffers.result_array`: aligned to a cache line, and
large ones recycled (see that module).

Example (the reference and the kernels agree)::

    >>> from kinematics import default_catalogue, compile_model
    >>> model = default_catalogue().get("ur5")
    >>> poe = compile_model(model)
    >>> Q = model.sample_configurations(5000, np.random.default_rng(0))
    >>> bool(np.abs(poe.fk(Q) - poe.fk_reference(Q)).max() < 1e-12)
    True
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..spatial.reference import Reference
from ..spatial.transforms import cross3, inverse_transform
from . import compiled, entries
from . import ik as ik_kernel
from . import velocity as velocity_kernel
from .buffers import result_array
from . import cancel
from .parallel import FK_MIN_ROWS, IK_PIECE_ROWS, run_rows

#: Configurations per chunk of the compiled kernels (a chunk's frames stay in L2).
CHUNK_SIZE = compiled.CHUNK
#: Plans (per list of requested links) kept per model.
PLAN_CACHE_SIZE = 256
#: An axis whose other components are at most this is taken as ± that coordinate axis
#: when building the axis frames (an exact signed permutation; the error is below this).
AXIS_ALIGNED_EPS = 1e-16

_REFERENCE_CODES = {Reference.WORLD: compiled.REF_WORLD, Reference.LOCAL_WORLD_ALIGNED: compiled.REF_LOCAL_WORLD_ALIGNED,
                    Reference.LOCAL: compiled.REF_LOCAL}


def axis_frame(w: np.ndarray, r: np.ndarray) -> np.ndarray:
    """A frame ``G`` (4x4) with origin ``r`` and z axis ``w`` (unit); exact for coordinate axes."""
    G = np.eye(4)
    G[:3, 3] = r
    k = int(np.argmax(np.abs(w)))
    others = np.delete(np.abs(w), k)
    if others.max() <= AXIS_ALIGNED_EPS:  # ± a coordinate axis: a signed permutation
        sign = 1.0 if w[k] > 0 else -1.0
        z = np.zeros(3)
        z[k] = sign
        x = np.zeros(3)
        x[(k + 1) % 3] = 1.0
        y = cross3(z, x)
    else:
        e = np.zeros(3)
        e[int(np.argmin(np.abs(w)))] = 1.0
        x = cross3(e, w)
        x /= np.linalg.norm(x)
        z = w / np.linalg.norm(w)
        y = cross3(z, x)
    G[:3, 0], G[:3, 1], G[:3, 2] = x, y, z
    return G


def with_tool(D: np.ndarray, tool: np.ndarray | None) -> np.ndarray:
    """The constant right factor(s) ``D`` (4, 4) or (L', 4, 4) times a tool offset ``T_link_tool``
    (unchanged when ``tool`` is None)."""
    if tool is None:
        return D
    return np.ascontiguousarray(np.matmul(D, np.asarray(tool, dtype=np.float64)))


def _zeroed(J: np.ndarray) -> np.ndarray:
    """``J`` filled with zeros (in place), for the Jacobian kernel, which adds each joint's column."""
    compiled.zero(J.reshape(-1))
    return J


@dataclass(frozen=True)
class _Plan:
    """What the compiled FK kernel computes for a list of output links."""

    order: np.ndarray  # (m,) int64 joints to compute, parents first
    lj: np.ndarray  # (L',) int64 per output: the joint frame it hangs from (-1: a constant pose)
    pose: np.ndarray  # (L', 4, 4) per output: the constant right factor (G_j^-1 M_L, or M_L)


class Kernel:
    """What the compiled kernels need of a :class:`~kinematics.engine.poe.PoEModel` (immutable).

    Attributes (n moving joints, L links):
        G: (n, 4, 4) the axis frames at q = 0 (z along the joint axis, origin on it).
        CZ: (n, 4, 4) ``G_parent^-1 G_j`` (``G_j`` at the root), the constant step of each joint.
        D4: (L, 4, 4) ``G_j^-1 M_L``, the constant right factor of each link's pose (zeros for
            links above every moving joint).
        dfs: the moving joints in depth-first order.
    """

    def __init__(self, poe):
        self.poe = poe
        n = len(poe.joint_names)
        L = len(poe.link_names)
        self.n, self.L = n, L
        G = np.array([axis_frame(poe.w[j], poe.r[j]) for j in range(n)]).reshape(n, 4, 4)
        CZ = np.empty((n, 4, 4))
        for j in range(n):
            p = poe.parent[j]
            CZ[j] = G[j] if p < 0 else inverse_transform(G[p]) @ G[j]
        D4 = np.zeros((L, 4, 4))
        for li in range(L):
            j = poe.link_joint[li]
            if j >= 0:
                D4[li] = inverse_transform(G[j]) @ poe.M[li]
        self.G, self.CZ, self.D4 = G, CZ, D4
        children: list[list[int]] = [[] for _ in range(n)]
        roots = []
        for j in range(n):  # parents precede children in PoEModel order
            p = poe.parent[j]
            (roots if p < 0 else children[p]).append(j)
        dfs: list[int] = []
        stack = list(reversed(roots))
        while stack:
            j = stack.pop()
            dfs.append(j)
            stack.extend(reversed(children[j]))
        self.dfs = tuple(dfs)
        # the compiled kernels' joint tables (see kinematics.engine.compiled)
        jint = np.zeros((n, 3), dtype=np.int64)
        jint[:, compiled.J_QINDEX] = poe.q_index
        jint[:, compiled.J_KIND] = poe.kind
        jint[:, compiled.J_PARENT] = poe.parent
        jflt = np.zeros((n, 14))
        jflt[:, compiled.J_MULT] = poe.multiplier
        jflt[:, compiled.J_OFFSET] = poe.offset
        jflt[:, compiled.J_CZ:] = CZ[:, :3, :].reshape(n, 12)
        self._jint, self._jflt = jint, jflt
        self._plans: dict[tuple[int, ...] | None, _Plan] = {}
        self._named: dict[tuple[str, ...], _Plan] = {}
        self._single: dict = {}  # bound single-configuration entries (kinematics.engine.entries)
        self._plan_all = self.plan(None)
        self._jplans: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._jcols: dict[int, np.ndarray] = {}
        for a in (jint, jflt, G, CZ, D4):
            a.setflags(write=False)

    # ------------------------------------------------------------------ FK
    def plan(self, link_idx: np.ndarray | None) -> _Plan:
        """The plan for output links ``link_idx`` (None: every link, in order)."""
        key = None if link_idx is None else tuple(int(i) for i in link_idx)
        plan = self._plans.get(key)
        if plan is not None:
            return plan
        poe = self.poe
        idx = np.arange(self.L) if link_idx is None else np.asarray(link_idx, dtype=np.intp)
        needed = np.zeros(self.n, dtype=bool)
        for li in idx:
            j = int(poe.link_joint[li])
            while j >= 0 and not needed[j]:
                needed[j] = True
                j = int(poe.parent[j])
        order = np.array([j for j in self.dfs if needed[j]], dtype=np.int64)
        lj = np.array([poe.link_joint[li] for li in idx], dtype=np.int64).reshape(len(idx))
        pose = np.array([self.D4[li] if poe.link_joint[li] >= 0 else poe.M[li] for li in idx]).reshape(len(idx), 4, 4)
        plan = _Plan(order=order, lj=lj, pose=pose)
        for a in (order, lj, pose):
            a.setflags(write=False)
        if len(self._plans) < PLAN_CACHE_SIZE:  # bounded cache; a plan is immutable
            self._plans[key] = plan
        return plan

    def named_plan(self, links) -> _Plan:
        """The plan for the links named ``links`` (a sequence of names; None: every link), from a cache
        keyed by the names: a repeated call (a single configuration at a time) resolves no name and
        builds no key of indices. An unknown name raises :class:`~kinematics.errors.UnknownLinkError`
        (and is not cached)."""
        if links is None:
            return self._plan_all
        key = links if type(links) is tuple else tuple(links)
        try:
            plan = self._named.get(key)
        except TypeError:  # not hashable (a list inside): resolved as it is, not cached
            return self.plan(self.poe.link_indices(links))
        if plan is None:
            plan = self.plan(self.poe.link_indices(key))
            if len(self._named) < PLAN_CACHE_SIZE:
                self._named[key] = plan
        return plan

    def fk(self, Q: np.ndarray, link_idx: np.ndarray | None = None, out: np.ndarray | None = None,
           chunk: int = CHUNK_SIZE, tool: np.ndarray | None = None, plan: _Plan | None = None) -> np.ndarray:
        """Poses ``T_world_link`` (N, L', 4, 4) of ``link_idx`` (None: all) for q (N, dof).

        One call of the compiled kernel (:func:`kinematics.engine.compiled.fk`) whatever N: a single
        configuration takes the same arithmetic as a row of a batch, bit for bit. ``tool``: a
        constant ``T_link_tool`` (4, 4) every output is right-multiplied by (folded into the
        constant factors: ``D @ T_link_tool``). ``plan``: the plan itself (:meth:`named_plan`), instead
        of ``link_idx``.
        """
        N = Q.shape[0]
        if plan is None:
            plan = self._plan_all if link_idx is None else self.plan(link_idx)
        n_out = plan.lj.shape[0]
        if out is None:
            out = result_array((N, n_out, 4, 4))
        if N == 1 and tool is None:  # one configuration: the single entry, same bits, a third of the call cost
            cancel.check()
            self._one_fk(plan)(np.ascontiguousarray(Q[0], dtype=np.float64), out[0])
        elif N:
            Q = np.ascontiguousarray(Q, dtype=np.float64)
            D, out3, c = with_tool(plan.pose, tool), out.reshape(N, n_out, 16), max(1, min(chunk, N))
            # rows split over threads (kinematics.engine.parallel): each row's bits do not depend on the split
            run_rows(lambda a, b: compiled.fk(Q[a:b], self._jint, self._jflt, plan.order, plan.lj, D, out3[a:b], c),
                     N, FK_MIN_ROWS, align=CHUNK_SIZE)
        return out

    def _one_fk(self, plan: _Plan):
        """``f(q, out)``: the single-configuration entry of :mod:`kinematics.engine.entries` bound to
        ``plan`` (built once per plan): one call of a compiled entry on packed tables instead of the
        batch kernel's eight arguments, so that a batch of one costs little more than ``fk_function``."""
        entry = self._single.get(id(plan))
        if entry is None or entry[0] is not plan:  # (an id may be reused by a plan that was not cached)
            entry = (plan, entries.bound_plan_fk(self, plan))
            if len(self._single) < PLAN_CACHE_SIZE:
                self._single[id(plan)] = entry
        return entry[1]

    def _one_jacobian(self, link_index: int, code: int):
        """``f(q, out)``: the single-configuration Jacobian entry of link ``link_index`` in reference
        ``code`` (:mod:`kinematics.engine.entries`), built once per link and reference."""
        key = (link_index, code)
        fn = self._single.get(key)
        if fn is None:
            fn = entries.bound_path_jacobian(self, link_index, code)
            if len(self._single) < 2 * PLAN_CACHE_SIZE:
                self._single[key] = fn
        return fn

    # ------------------------------------------------------------------ velocities
    def velocity(self, Q: np.ndarray, Qd: np.ndarray, link_idx: np.ndarray | None = None,
                 tool: np.ndarray | None = None, chunk: int = CHUNK_SIZE) -> np.ndarray:
        """Twists (3, N, L', 6) of ``link_idx`` (None: all) for q and qdot (N, dof): ``[c]`` in the
        reference of kernel code ``c`` (``compiled.REF_*``), linear part first
        (:func:`kinematics.engine.velocity.velocities`, one pass down the tree)."""
        N = Q.shape[0]
        plan = self._plan_all if link_idx is None else self.plan(link_idx)
        if not (N and plan.order.shape[0]):
            return np.zeros((3, N, plan.lj.shape[0], 6))
        out = np.empty((3, N, plan.lj.shape[0], 6))
        Q, Qd, D = np.ascontiguousarray(Q, dtype=np.float64), np.ascontiguousarray(Qd, dtype=np.float64), with_tool(plan.pose, tool)
        step = N if cancel.current() is None else cancel.CANCEL_PIECE_ROWS
        for a in range(0, N, step):  # cancellable: pieces (into their own buffer), checked before each
            b = min(a + step, N)
            part = out if b - a == N else np.empty((3, b - a, plan.lj.shape[0], 6))
            cancel.check()
            velocity_kernel.velocities(Q[a:b], Qd[a:b], self._jint, self._jflt, plan.order, plan.lj, D, part,
                                       max(1, min(chunk, b - a)))
            if part is not out:
                out[:, a:b] = part
        return out

    # ------------------------------------------------------------------ Jacobians
    def path(self, link_index: int) -> np.ndarray:
        """Moving joints from the root to link ``link_index``, root first: (k,) int64."""
        out = []
        j = int(self.poe.link_joint[link_index])
        while j >= 0:
            out.append(j)
            j = int(self.poe.parent[j])
        return np.array(out[::-1], dtype=np.int64)

    def path_plan(self, link_index: int) -> tuple[np.ndarray, np.ndarray]:
        """``(path, D)`` of a link: its moving joints root first, and its constant factor ``G^-1 M``."""
        jp = self._jplans.get(link_index)
        if jp is None:
            jp = (self.path(link_index), np.ascontiguousarray(self.D4[link_index]))
            for a in jp:
                a.setflags(write=False)
            if len(self._jplans) < PLAN_CACHE_SIZE:
                self._jplans[link_index] = jp
        return jp

    def path_columns(self, link_index: int) -> np.ndarray:
        """The q columns the joints on a link's path drive (mimic joints: their leader's), sorted."""
        cols = self._jcols.get(link_index)
        if cols is None:
            cols = np.unique(self._jint[self.path_plan(link_index)[0], compiled.J_QINDEX]).astype(np.int64)
            cols.setflags(write=False)
            if len(self._jcols) < PLAN_CACHE_SIZE:
                self._jcols[link_index] = cols
        return cols

    def jacobian(self, Q: np.ndarray, link_index: int, reference: str, chunk: int = CHUNK_SIZE,
                 tool: np.ndarray | None = None) -> np.ndarray:
        """Jacobian (N, 6, dof) of link ``link_index``, linear rows first, in ``reference``.

        ``reference``: ``world`` (twist at the world origin, world axes), ``local_world_aligned``
        (velocity of the link origin and angular velocity, world axes) or ``local`` (the same in
        the link's axes); the caller has validated it. ``tool``: ``T_link_tool`` (4, 4), the frame
        whose Jacobian it is (Pinocchio's frame semantics: its origin is the reference point of
        ``local_world_aligned``, its axes those of ``local``).
        """
        N = Q.shape[0]
        J = result_array((N, 6, Q.shape[1]))  # zeroed by each thread for its rows (the kernel adds columns)
        if N == 1 and tool is None:  # one configuration: the single entry (zeroes J itself), same bits
            cancel.check()
            self._one_jacobian(link_index, _REFERENCE_CODES[reference])(np.ascontiguousarray(Q[0], dtype=np.float64), J[0])
            return J
        path, D = self.path_plan(link_index)
        D = with_tool(D, tool)
        if N and len(path):
            Q = np.ascontiguousarray(Q, dtype=np.float64)
            code, c = _REFERENCE_CODES[reference], max(1, min(chunk, N))
            run_rows(lambda a, b: compiled.jacobian(Q[a:b], self._jint, self._jflt, path, D, code, _zeroed(J[a:b]), c),
                     N, FK_MIN_ROWS, align=CHUNK_SIZE)
        elif N:
            J.fill(0.0)
        return J

    # ------------------------------------------------------------------ inverse kinematics
    def ik(self, Q: np.ndarray, targets: np.ndarray, link_index: int, joints: tuple, settings: tuple,
           streams: np.ndarray, tool: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Inverse kinematics (:func:`kinematics.engine.ik.solve`) of link ``link_index`` for targets
        ``T_root_link`` (N, 4, 4) from seeds ``Q`` (N, dof): ``(Q, position_error, rotation_error,
        steps)`` of the best configurations found. ``joints``: ``(lower, upper, wrap, angular)``, the
        model's joint arrays; ``settings``: ``(position_only, tol_position, tol_rotation, max_iterations,
        restarts, damping, polish, stall)``; ``streams``: the restarts' random streams per target. Only
        the path's q columns move. ``tool``:
        ``T_link_tool`` (4, 4): the targets are the tool frame's poses; the solver is unchanged, it
        places ``F_last · D`` and the tool only turns the link's constant ``D`` into ``D @ T_link_tool``."""
        position_only, tol_position, tol_rotation, max_iterations, restarts, damping, polish, stall = settings
        path, D = self.path_plan(link_index)
        D = with_tool(D, tool)
        N = Q.shape[0]
        Q = np.array(Q, dtype=np.float64, order="C")
        perr, rerr, steps = np.zeros(N), np.zeros(N), np.zeros(N, dtype=np.int64)
        cols = self.path_columns(link_index)
        if N == 0 or len(cols) == 0:  # nothing moves the link: the seeds stay (the caller measures them)
            return Q, perr, rerr, steps
        targets = np.ascontiguousarray(targets, dtype=np.float64)
        kernel_settings = (ik_kernel.MODE_POSITION if position_only else ik_kernel.MODE_POSE, float(tol_position),
                           float(tol_rotation), int(max_iterations), int(restarts), float(damping), float(polish),
                           int(stall))
        chain = (cols, self._jint, self._jflt, path, D)

        def solve(a, b):  # each target is solved on its own: the split over threads changes no bit
            ik_kernel.solve(Q[a:b], targets[a:b], joints, chain, kernel_settings, streams[a:b],
                            (perr[a:b], rerr[a:b], steps[a:b]))

        run_rows(solve, N, min_rows=IK_PIECE_ROWS, piece_rows=IK_PIECE_ROWS)
        return Q, perr, rerr, steps
