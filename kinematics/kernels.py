"""Fast batched kernels for the product of exponentials (structure of arrays, chunked).

These kernels evaluate exactly the product of :mod:`kinematics.poe`,

    T_world_L(q) = exp([S_1] θ_1) ... exp([S_k] θ_k) M_L,

but arrange the arithmetic so that a batch costs little per configuration. FK runs the
compiled kernel of :mod:`kinematics.compiled` (numba; one pass per chunk, every pose
written once into the result); the Jacobians run numpy structure-of-arrays code, a few
large operations per joint. The reference implementation (``PoEModel.fk_reference``,
``PoEModel.jacobian_reference``) stays the definition; ``tests/test_kernels.py`` checks
that both agree to 1e-12 on every catalogue model.

The regrouping
--------------
Each joint's screw ``S_j`` is a rotation about (or a translation along) a line. Put a
frame ``G_j`` on that line with its z axis along the axis (``G_j`` is built from ``w_j`` and
``r_j`` only). Then ``exp([S_j] θ) = G_j Z(θ) G_j^-1`` where ``Z(θ)`` is the rotation about
(revolute) or translation along (prismatic) the z axis. With the prefix products
``P_j = P_parent(j) exp([S_j] θ_j)`` and the "axis frames" ``F_j = P_j G_j``:

    F_j = F_parent(j) · (G_parent^-1 G_j) · Z(θ_j)        (F_parent = I, G_parent = I at the root)
    T_world_L = F_j · (G_j^-1 M_L)                       (j: the last moving joint above L)

Both constant factors are precomputed. Right-multiplying by ``Z(θ)`` only mixes the first
two rotation columns of ``F_j`` with ``cos θ`` and ``sin θ`` (prismatic: adds ``θ`` times the
third column to the translation), and ``F_j``'s third column and origin are the joint axis
and a point on it in world coordinates, which is all the Jacobian needs.

Layout (Jacobians)
------------------
A batch of frames is one ``(13, C)`` float64 buffer per joint of the path: rows ``3c + r``
hold ``T[r, c]`` (the columns of the 3x4 part: three rotation columns, then the
translation) and row 12 holds ones; ``C`` configurations (a chunk) run along the fast
axis. Then

- the constant right-product ``F · K`` is one matrix product ``K^T (4, 4) @ F (4, 3C)``;
- the mixing by ``Z(θ)`` is four in-place element-wise calls on the ``(2, 3, C)`` rows of
  the first two columns;
- sine and cosine come from a vectorised polynomial (fdlibm's kernels, Cody-Waite
  reduction by π/2), about twice as fast as ``np.sin`` plus ``np.cos`` here, and within an
  ulp of them; arguments beyond ``SINCOS_MAX_ARG`` fall back to numpy.

Memory is ``O(path length · chunk)`` whatever N. Batches of at most ``SMALL_BATCH``
configurations take a path with few numpy calls: all factors ``CZ_j Z(θ_j)`` in one
product, then the prefix products by pointer jumping (``_frames_small``).

FK results come from :func:`kinematics.buffers.result_array`: aligned to a cache line, and
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
from typing import TYPE_CHECKING

import numpy as np

from . import compiled
from .buffers import aligned_empty, result_array

if TYPE_CHECKING:  # pragma: no cover
    from .poe import PoEModel

#: Configurations per chunk of the batched kernels (bounds memory; cache friendly).
CHUNK_SIZE = 2048
#: Elements per block of the polynomial sine/cosine (bounds its scratch; larger blocks mean
#: fewer numpy calls: 16,384 measured best here).
SINCOS_BLOCK = 16384
#: Batches up to this size take the small-batch path (few numpy calls, batched 4x4 products).
SMALL_BATCH = 16
#: Visiting plans (per list of requested links) kept per model.
PLAN_CACHE_SIZE = 256
#: Largest |θ| for which the polynomial sine/cosine is used (exact reduction below 2^20 · π/2).
SINCOS_MAX_ARG = 1.0e6
#: An axis whose other components are at most this is taken as ± that coordinate axis
#: when building the axis frames (an exact signed permutation; the error is below this).
AXIS_ALIGNED_EPS = 1e-16

REVOLUTE, PRISMATIC = 0, 1  # same codes as kinematics.poe

# --- polynomial sine and cosine -------------------------------------------------------------
# fdlibm (__kernel_sin, __kernel_cos, __ieee754_rem_pio2): on |r| <= π/4 the polynomials are
# accurate to < 2^-58. π/2 = _PIO2_1 + _PIO2_1T with a 33-bit first part, so k·_PIO2_1 is exact
# and th - k·_PIO2_1 too for |k| < 2^20; the absolute error of r stays ~1e-20 (we need absolute,
# not relative, accuracy near multiples of π/2, so fdlibm's third part is not needed).
_TWO_OVER_PI = 6.36619772367581382433e-01
_PIO2_1 = 1.57079632673412561417e00  # first 33 bits of π/2
_PIO2_1T = 6.07710050650619224932e-11  # π/2 - _PIO2_1
_SIN_COEFFS = (
    1.58969099521155010221e-10, -2.50507602534068634195e-08, 2.75573137070700676789e-06,
    -1.98412698298579493134e-04, 8.33333333332248946124e-03, -1.66666666666666324348e-01,
)
_COS_COEFFS = (
    -1.13596475577881948265e-11, 2.08757232129817482790e-09, -2.75573143513906633035e-07,
    2.48015872894767294178e-05, -1.38888888888741095749e-03, 4.16666666666666019037e-02,
)


def _sincos_block(th, s, c, k, r, z, a, b, m) -> None:
    """sin and cos of a contiguous 1-D block ``th`` into ``s``, ``c``; ``k..b`` (float) and ``m``
    (int64) are scratch of the same length."""
    np.multiply(th, _TWO_OVER_PI, out=k)
    np.rint(k, out=k)  # quadrant index (float)
    np.multiply(k, _PIO2_1, out=a)
    np.subtract(th, a, out=r)
    np.multiply(k, _PIO2_1T, out=a)
    r -= a  # r = th - k·π/2 in [-π/4, π/4], to ~1e-20 for |th| <= SINCOS_MAX_ARG
    np.multiply(r, r, out=z)
    np.multiply(z, _SIN_COEFFS[0], out=s)
    for coeff in _SIN_COEFFS[1:]:
        s += coeff
        s *= z
    s *= r
    s += r  # sin r
    np.multiply(z, _COS_COEFFS[0], out=c)
    for coeff in _COS_COEFFS[1:]:
        c += coeff
        c *= z
    c *= z
    np.multiply(z, 0.5, out=a)
    c -= a
    c += 1.0  # cos r
    # rotate by k·π/2: with m = k mod 4, A = cos(mπ/2) = |m-2|-1, B = sin(mπ/2) = 1-|m-1|
    np.copyto(m, k, casting="unsafe")
    m &= 3
    np.subtract(m, 2.0, out=a)
    np.abs(a, out=a)
    a -= 1.0  # A
    np.subtract(m, 1.0, out=k)
    np.abs(k, out=k)
    np.subtract(1.0, k, out=k)  # B
    np.multiply(s, k, out=b)  # B sin r
    np.multiply(c, k, out=z)  # B cos r
    c *= a
    c -= b  # cos th = A cos r - B sin r
    s *= a
    s += z  # sin th = A sin r + B cos r


def sincos(theta: np.ndarray, s: np.ndarray | None = None, c: np.ndarray | None = None,
           scratch: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(sin θ, cos θ)`` of a float64 array, elementwise, within an ulp of ``np.sin``/``np.cos``.

    ``s`` and ``c`` (same shape, contiguous) may be given to write into, and ``scratch`` (from
    :func:`sincos_scratch`) to reuse across calls. Arguments with ``|θ| > SINCOS_MAX_ARG`` or
    non-finite values make the whole call use numpy's functions.

    >>> s, c = sincos(np.array([0.0, np.pi / 6, 100.0]))
    >>> bool(np.allclose(s, [0.0, 0.5, np.sin(100.0)], atol=1e-15, rtol=0))
    True
    """
    th = np.ascontiguousarray(theta, dtype=float)
    s = np.empty_like(th) if s is None else s
    c = np.empty_like(th) if c is None else c
    flat, sf, cf = th.reshape(-1), s.reshape(-1), c.reshape(-1)
    m = flat.size
    if m == 0:
        return s, c
    lo, hi = flat.min(), flat.max()
    if not (-SINCOS_MAX_ARG <= lo and hi <= SINCOS_MAX_ARG):  # also catches NaN
        np.sin(flat, out=sf)
        np.cos(flat, out=cf)
        return s, c
    if scratch is None or scratch[1].size < min(SINCOS_BLOCK, m):
        scratch = sincos_scratch(m)
    work, quadrant = scratch
    blk = min(quadrant.size, m)
    for i in range(0, m, blk):
        j = min(m, i + blk)
        w = j - i
        _sincos_block(flat[i:j], sf[i:j], cf[i:j], *(x[:w] for x in work), quadrant[:w])
    return s, c


def sincos_scratch(size: int) -> tuple[np.ndarray, np.ndarray]:
    """Scratch for :func:`sincos` of up to ``size`` elements per block (at most ``SINCOS_BLOCK``)."""
    blk = max(1, min(SINCOS_BLOCK, size))
    return np.empty((5, blk)), np.empty(blk, dtype=np.int64)


#: small Jacobian batches: one batched 4x4 product per joint is preferred while there are at
#: most this many per pointer-jumping product it replaces
SEQUENTIAL_CALLS_PER_JUMP = 3


# --- compiled kernel ------------------------------------------------------------------------
def _axis_frame(w: np.ndarray, r: np.ndarray) -> np.ndarray:
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
        y = np.cross(z, x)
    else:
        e = np.zeros(3)
        e[int(np.argmin(np.abs(w)))] = 1.0
        x = np.cross(e, w)
        x /= np.linalg.norm(x)
        z = w / np.linalg.norm(w)
        y = np.cross(z, x)
    G[:3, 0], G[:3, 1], G[:3, 2] = x, y, z
    return G


def _inverse(T: np.ndarray) -> np.ndarray:
    Ti = np.eye(4)
    Ti[:3, :3] = T[:3, :3].T
    Ti[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return Ti


@dataclass(frozen=True)
class _Plan:
    """What the compiled FK kernel computes for a list of output links."""

    order: np.ndarray  # (m,) int64 joints to compute, parents first
    lj: np.ndarray  # (L',) int64 per output: the joint frame it hangs from (-1: a constant pose)
    pose: np.ndarray  # (L', 4, 4) per output: the constant right factor (G_j^-1 M_L, or M_L)


class Kernel:
    """The structure-of-arrays form of a :class:`~kinematics.poe.PoEModel` (immutable).

    Attributes (n moving joints, L links):
        K: (n, 4, 4) ``(G_parent^-1 G_j)^T``, the constant step of each joint, transposed.
        root_frame: (n, 12) the frame vector of ``G_j`` (used for joints at the root).
        D4: (L, 4, 4) ``G_j^-1 M_L``, the constant right factor of each link's pose (zeros for
            links above every moving joint).
        CZ: (n, 4, 4) ``(G_parent^-1 G_j)``.
        depth: (n,) depth of each joint among the moving joints (buffer index).
    """

    def __init__(self, poe: "PoEModel"):
        self.poe = poe
        n = len(poe.joint_names)
        L = len(poe.link_names)
        self.n, self.L = n, L
        G = np.array([_axis_frame(poe.w[j], poe.r[j]) for j in range(n)]).reshape(n, 4, 4)
        self.G = G
        CZ = np.empty((n, 4, 4))
        for j in range(n):
            p = poe.parent[j]
            CZ[j] = G[j] if p < 0 else _inverse(G[p]) @ G[j]
        self.CZ = CZ
        self.K = np.ascontiguousarray(np.swapaxes(CZ, 1, 2))
        self.root_frame = np.ascontiguousarray(np.swapaxes(G[:, :3, :], 1, 2)).reshape(n, 12)
        D4 = np.zeros((L, 4, 4))
        for li in range(L):
            j = poe.link_joint[li]
            if j >= 0:
                D4[li] = _inverse(G[j]) @ poe.M[li]
        self.D4 = D4
        depth = np.zeros(n, dtype=np.intp)
        children: list[list[int]] = [[] for _ in range(n)]
        roots = []
        for j in range(n):  # parents precede children in PoEModel order
            p = poe.parent[j]
            if p < 0:
                roots.append(j)
            else:
                depth[j] = depth[p] + 1
                children[p].append(j)
        self.depth = depth
        self.n_depth = int(depth.max()) + 1 if n else 0
        dfs: list[int] = []
        stack = list(reversed(roots))
        while stack:
            j = stack.pop()
            dfs.append(j)
            stack.extend(reversed(children[j]))
        self.dfs = tuple(dfs)
        self.kind = np.asarray(poe.kind)
        self.q_index = np.asarray(poe.q_index)
        self.multiplier = np.asarray(poe.multiplier)
        self.offset = np.asarray(poe.offset)
        self.plain_q = bool(
            np.array_equal(self.q_index, np.arange(n)) and np.all(self.multiplier == 1.0) and np.all(self.offset == 0.0)
        )
        rot = self.kind == REVOLUTE
        # CZ_j Z(θ) = CZ_j + sin θ · CZ_j [z] + (1 - cos θ) · CZ_j [z]^2 (revolute; [z] the skew
        # matrix of the z axis) or CZ_j + θ · CZ_j T_z (prismatic; T_z the unit z translation),
        # written as w · basis with w = (1, sin θ, cos θ, θ) and a basis row of zeros where unused.
        Kz = np.zeros((4, 4))
        Kz[0, 1], Kz[1, 0] = -1.0, 1.0
        Tz = np.zeros((4, 4))
        Tz[2, 3] = 1.0
        B = CZ @ Kz @ Kz
        b0 = np.where(rot[:, None, None], CZ + B, CZ)
        b1 = np.where(rot[:, None, None], CZ @ Kz, 0.0)
        b2 = np.where(rot[:, None, None], -B, 0.0)
        b3 = np.where(rot[:, None, None], 0.0, CZ @ Tz)
        eye = np.zeros((1, 4, 16))
        eye[0, 0] = np.eye(4).reshape(16)
        # (n + 1, 4, 16): w = (1, sin θ, cos θ, θ) times this is CZ_j Z(θ_j); the last slot is I
        self._basis = np.concatenate([np.stack([b0, b1, b2, b3], axis=1).reshape(n, 4, 16), eye])
        self._w_template = np.zeros((n + 1, 1, 4))
        self._w_template[:, 0, 0] = 1.0
        self._has_prismatic = bool((~rot).any())
        # θ = Q @ q_map + offset (mimic joints: multiplier times the leader's column)
        q_map = np.zeros((poe.model.dof, n))
        q_map[self.q_index, np.arange(n)] = self.multiplier
        self._q_map = q_map
        self._has_offset = bool(np.any(self.offset != 0.0))
        # pointer jumping: after step s, F_j holds the product over its 2^(s+1) nearest ancestors
        anc = np.where(poe.parent >= 0, poe.parent, n).astype(np.intp)
        anc = np.append(anc, n)
        jumps = []
        span = 1
        while span < self.n_depth:
            jumps.append(anc.copy())
            anc = anc[anc]
            span *= 2
        self._jumps = tuple(jumps)
        # a chain prefix (parent of j is j - 1) then leaf joints hanging from it: slices, no gathers
        m = 0
        while m < n and poe.parent[m] == m - 1:
            m += 1
        rest = np.arange(m, n)
        self._chain = m if n and np.all(poe.parent[rest] < m) and not np.isin(rest, poe.parent).any() else 0
        self._chain_leaves = rest
        self._chain_leaf_parents = np.asarray(poe.parent[rest], dtype=np.intp)
        # small batches: the prefix products one 4x4 product per joint when that is fewer calls
        # than pointer jumping
        self._one_steps = tuple((j, int(poe.parent[j])) for j in self.dfs if poe.parent[j] >= 0)
        jump_calls = (int(np.ceil(np.log2(m))) if m > 1 else 0) + (len(rest) > 0) if self._chain else len(jumps)
        self._one_sequential = n > 0 and len(self._one_steps) <= SEQUENTIAL_CALLS_PER_JUMP * jump_calls
        # the compiled FK kernel's joint tables (see kinematics.compiled)
        jint = np.zeros((n, 3), dtype=np.int64)
        jint[:, compiled.J_QINDEX] = self.q_index
        jint[:, compiled.J_KIND] = self.kind
        jint[:, compiled.J_PARENT] = poe.parent
        jflt = np.zeros((n, 14))
        jflt[:, compiled.J_MULT] = self.multiplier
        jflt[:, compiled.J_OFFSET] = self.offset
        jflt[:, compiled.J_CZ:] = CZ[:, :3, :].reshape(n, 12)
        self._jint, self._jflt = jint, jflt
        self._plans: dict[tuple[int, ...] | None, _Plan] = {}
        self._plan_all = self.plan(None)
        self._jplans: dict[int, tuple] = {}
        for a in (self._jint, self._jflt, self.K, self.root_frame, self.D4, self.CZ, self._basis, self.depth, self._w_template, self._q_map):
            a.setflags(write=False)

    # ------------------------------------------------------------------ plans
    def plan(self, link_idx: np.ndarray | None) -> _Plan:
        """The visiting plan for output links ``link_idx`` (None: every link, in order)."""
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

    # ------------------------------------------------------------------ FK
    def fk(self, Q: np.ndarray, link_idx: np.ndarray | None = None, out: np.ndarray | None = None,
           chunk: int = compiled.CHUNK) -> np.ndarray:
        """Poses ``T_world_link`` (N, L', 4, 4) of ``link_idx`` (None: all) for q (N, dof).

        One call of the compiled kernel (:func:`kinematics.compiled.fk`) whatever N: a single
        configuration takes the same arithmetic as a row of a batch, bit for bit.
        """
        N = Q.shape[0]
        plan = self._plan_all if link_idx is None else self.plan(link_idx)
        n_out = plan.lj.shape[0]
        if out is None:
            out = result_array((N, n_out, 4, 4))
        if N:
            Q = np.ascontiguousarray(Q, dtype=np.float64)
            compiled.fk(Q, self._jint, self._jflt, plan.order, plan.lj, plan.pose, out.reshape(N, n_out, 16),
                        max(1, min(chunk, N)))
        return out

    def _joint_step(self, Fp, Fj, j: int, s, c, th, t) -> None:
        """``F_j = F_parent · CZ_j · Z(θ_j)`` for a chunk: frame vectors (13, C); ``Fp`` None at the root.

        ``s``, ``c``, ``th``: (C,) sin θ, cos θ, θ; ``t``: (2, 3, C) scratch.
        """
        C = Fj.shape[1]
        if Fp is None:
            Fj[:12] = self.root_frame[j][:, None]
        else:
            np.matmul(self.K[j], Fp[:12].reshape(4, 3 * C), out=Fj[:12].reshape(4, 3 * C))
        if self.kind[j] == REVOLUTE:
            xy = Fj[0:6].reshape(2, 3, C)  # the first two rotation columns
            np.multiply(xy[::-1], s, out=t)  # (s·y, s·x)
            xy *= c
            xy[0] += t[0]  # x' = c·x + s·y
            xy[1] -= t[1]  # y' = c·y - s·x
        else:
            np.multiply(Fj[6:9], th, out=t[0])
            Fj[9:12] += t[0]  # t' = t + θ·z

    # ------------------------------------------------------------------ small batches
    def _frames_small(self, Q: np.ndarray) -> np.ndarray:
        """Axis frames F (N, n + 1, 4, 4) of every moving joint for a small batch (F[:, n] = I).

        ``CZ_j Z(θ_j)`` for all joints in one product, then the prefix products along the
        tree by pointer jumping: ``ceil(log2(depth))`` batched products instead of ``n``.
        Few numpy calls, so little overhead for one or a few configurations.
        """
        n = self.n
        N = Q.shape[0]
        if self.plain_q:
            th = Q
        else:
            th = Q @ self._q_map
            if self._has_offset:
                th += self.offset
        if N == 1:
            w = self._w_template[None].copy()
        else:
            w = np.empty((N, n + 1, 1, 4))
            w[...] = self._w_template
        np.sin(th, out=w[:, :n, 0, 1])
        np.cos(th, out=w[:, :n, 0, 2])
        if self._has_prismatic:
            w[:, :n, 0, 3] = th
        F = np.matmul(w, self._basis).reshape(N, n + 1, 4, 4)  # CZ_j Z(θ_j); F[:, n] = I
        if self._one_sequential:  # short trees: one product per joint costs fewer calls than pointer jumping
            P = F.copy()
            for j, p in self._one_steps:
                np.matmul(P[:, p], F[:, j], out=P[:, j])
            return P
        m = self._chain
        if m:  # a chain prefix: the ancestors are slices (no gathers); then its leaf joints
            span = 1
            while span < m:  # the product reads the old frames before they are overwritten
                F[:, span:m] = np.matmul(F[:, :m - span], F[:, span:m])
                span *= 2
            if len(self._chain_leaves):
                F[:, self._chain_leaves] = np.matmul(F[:, self._chain_leaf_parents], F[:, self._chain_leaves])
            return F
        for anc in self._jumps:
            F = np.matmul(F[:, anc], F)
        return F

    # ------------------------------------------------------------------ Jacobians
    def path(self, link_index: int) -> np.ndarray:
        """Moving joints from the root to link ``link_index``, root first: (k,)."""
        out = []
        j = int(self.poe.link_joint[link_index])
        while j >= 0:
            out.append(j)
            j = int(self.poe.parent[j])
        return np.array(out[::-1], dtype=np.intp)

    def jacobian(self, Q: np.ndarray, link_index: int, reference: str, chunk: int = CHUNK_SIZE) -> np.ndarray:
        """Jacobian (N, 6, dof) of link ``link_index``, linear rows first, in ``reference``.

        ``reference``: ``world`` (twist at the world origin, world axes), ``local_world_aligned``
        (velocity of the link origin and angular velocity, world axes) or ``local`` (the same in
        the link's axes); the caller has validated it.
        """
        N = Q.shape[0]
        J = np.zeros((N, 6, Q.shape[1]))
        jp = self._jacobian_plan(link_index)
        path, qi, mult, plain, rev, D4T, lo, contiguous = jp
        if N == 0 or len(path) == 0:
            return J
        if N <= SMALL_BATCH:
            Js = self._jacobian_small(Q, path, rev, link_index, reference)  # (N, 6, k)
            if contiguous:
                J[:, :, lo:lo + len(path)] = Js
            elif plain:
                J[:, :, qi] = Js
            else:
                for i in range(len(path)):
                    J[:, :, qi[i]] += mult[i] * Js[:, :, i]
            return J
        for a in range(0, N, chunk):
            b = min(N, a + chunk)
            Js = self._jacobian_chunk(Q[a:b], path, rev, D4T, reference)  # (6, k, C)
            Jc = J[a:b]
            if contiguous:  # one transposing copy into a block of columns
                np.copyto(Jc[:, :, lo:lo + len(qi)], Js.transpose(2, 0, 1))
            elif plain:
                for i in range(len(path)):
                    np.copyto(Jc[:, :, qi[i]], Js[:, i, :].T)
            else:  # mimic joints add their column (times the multiplier) to the leader's
                for i in range(len(path)):
                    Jc[:, :, qi[i]] += mult[i] * Js[:, i, :].T
        return J

    def _jacobian_plan(self, link_index: int):
        """(path, q columns, multipliers, plain, revolute mask, D4^T, first column, contiguous) of a link."""
        jp = self._jplans.get(link_index)
        if jp is None:
            path = self.path(link_index)
            qi = self.q_index[path]
            mult = self.multiplier[path]
            plain = len(set(qi.tolist())) == len(qi) and bool(np.all(mult == 1.0))
            lo = int(qi.min()) if len(qi) else 0
            contiguous = plain and bool(np.array_equal(qi, np.arange(lo, lo + len(qi))))
            D4T = np.ascontiguousarray(self.D4[link_index].T)
            jp = (path, qi, mult, plain, self.kind[path] == REVOLUTE, D4T, lo, contiguous)
            if len(self._jplans) < PLAN_CACHE_SIZE:
                self._jplans[link_index] = jp
        return jp

    def _jacobian_chunk(self, Qc, path, rev, D4T, reference) -> np.ndarray:
        k = len(path)
        C = Qc.shape[0]
        th = Qc[:, self.q_index[path]].T * self.multiplier[path][:, None] + self.offset[path][:, None]
        S, Cs = sincos(th)
        F = aligned_empty((k, 13, C))
        F[:, 12] = 1.0
        t = np.empty((2, 3, C))
        for i, j in enumerate(path):  # a path is a chain: joint i sits at depth i in F
            self._joint_step(F[i - 1] if i else None, F[i], j, S[i], Cs[i], th[i], t)
        W = np.moveaxis(F[:, 6:9], 1, 0)  # (3, k, C) joint axes, world
        P = np.moveaxis(F[:, 9:12], 1, 0)  # (3, k, C) points on the axes, world
        Js = np.empty((6, k, C))
        lin, ang = Js[:3], Js[3:]
        ang[...] = W
        if reference == "world":
            Dp = -P  # v = ω × (0 - p)
        else:
            U = np.matmul(D4T, F[-1, :12].reshape(4, 3 * C)).reshape(4, 3, C)  # columns of T_world_L
            Dp = U[3][:, None, :] - P  # ω × (p_L - p): velocity of the link origin
        np.multiply(W[1], Dp[2], out=lin[0])
        lin[0] -= W[2] * Dp[1]
        np.multiply(W[2], Dp[0], out=lin[1])
        lin[1] -= W[0] * Dp[2]
        np.multiply(W[0], Dp[1], out=lin[2])
        lin[2] -= W[1] * Dp[0]
        if not rev.all():
            pri = ~rev
            lin[:, pri] = W[:, pri]
            ang[:, pri] = 0.0
        if reference == "local":
            R = U[:3]  # R[c, r] = R_world_L[r, c]
            out = np.empty_like(Js)
            tmp = np.empty((k, C))
            for block in (0, 3):  # R^T v: component c = column c · v
                v = Js[block:block + 3]
                for c in range(3):
                    o = out[block + c]
                    np.multiply(v[0], R[c, 0], out=o)
                    np.multiply(v[1], R[c, 1], out=tmp)
                    o += tmp
                    np.multiply(v[2], R[c, 2], out=tmp)
                    o += tmp
            Js = out
        return Js

    def _jacobian_small(self, Q, path, rev, link_index, reference) -> np.ndarray:
        """(N, 6, k) Jacobian columns of the path joints for a small batch."""
        F = self._frames_small(Q)
        Fp = F[:, path]  # (N, k, 4, 4)
        W = np.swapaxes(Fp[:, :, :3, 2], 1, 2)  # (N, 3, k) joint axes, world
        P = np.swapaxes(Fp[:, :, :3, 3], 1, 2)  # (N, 3, k) points on the axes
        if reference == "world":
            Dp = -P
        else:
            T_L = F[:, path[-1]] @ self.D4[link_index]  # (N, 4, 4)
            Dp = T_L[:, :3, 3, None] - P
        Js = np.empty((Q.shape[0], 6, len(path)))
        for r, (a, b) in enumerate(((1, 2), (2, 0), (0, 1))):  # lin = ω × Dp
            np.multiply(W[:, a], Dp[:, b], out=Js[:, r])
            Js[:, r] -= W[:, b] * Dp[:, a]
        Js[:, 3:] = W
        if not rev.all():
            pri = ~rev
            Js[:, :3, pri] = W[:, :, pri]
            Js[:, 3:, pri] = 0.0
        if reference == "local":
            Rt = np.swapaxes(T_L[:, :3, :3], 1, 2)  # (N, 3, 3)
            Js[:, :3] = Rt @ Js[:, :3]
            Js[:, 3:] = Rt @ Js[:, 3:]
        return Js
