"""Compiled (numba) kernels: forward kinematics and Jacobians over batches, one pass per
chunk of configurations with every intermediate in registers or cache.

They compute the axis-frame products of :mod:`kinematics.engine.plans` (which precomputes
their constants),

    F_j = F_parent(j) · CZ_j · Z(θ_j)           T_world_L = F_j · D_L

with loops that LLVM vectorises over the configurations of a chunk, and write each pose
or Jacobian column once, straight into the result (``bench/RESULTS.md`` has the figures,
and what the numpy version of the same products reached).

- Joint values: ``θ_j = multiplier_j · q[q_index_j] + offset_j`` (mimic joints), then sine
  and cosine by fdlibm's polynomials with an exact Cody-Waite reduction for
  ``|θ| <= SINCOS_MAX_ARG`` (larger or non-finite values: libm), within an ulp of libm.
- Frames: structure of arrays ``F[j, 12, chunk]`` (row ``4r + c`` holds ``F[r, c]``), the
  rows padded so that they are not 4 KiB apart (rows exactly 4 KiB apart alias in L1).
- FK: configuration by configuration, every requested link's 4x4 written contiguously.
- Jacobians: the frames of the link's path, then per configuration each joint's column
  ``(ω × (o - p), ω)`` (revolute) or ``(axis, 0)`` (prismatic), rotated into the link's
  axes for ``local``, added to its q column times its multiplier.

No fast-math: LLVM does not contract or reassociate, so the vectorised body and its
scalar remainder give the same bits, and a single configuration equals its row of a batch.
Functions are compiled on first use and cached on disk (``cache=True``; numba keeps the
cache next to this file when it can write there, else in ``~/.cache/numba``, or in
``NUMBA_CACHE_DIR``): the first run on a machine takes a few seconds, later processes
load the cache in well under a second (:func:`kinematics.usecases.warm_up` does it at server start).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

#: joint kinds in the kernels' tables (``PoEModel.kind``)
REVOLUTE, PRISMATIC = 0, 1

#: Configurations per chunk of the compiled kernel (frames of one chunk stay in L2).
CHUNK = 256
#: Padding (float64 elements) of each frame row, so rows of a chunk are not 4 KiB apart.
ROW_PAD = 8
#: Largest |θ| reduced exactly by the polynomial sine/cosine (|k| < 2^20 quadrants).
SINCOS_MAX_ARG = 1.0e6

# fdlibm (__kernel_sin, __kernel_cos, __ieee754_rem_pio2): on |r| <= π/4 the polynomials are
# accurate to < 2^-58. π/2 = _PIO2_1 + _PIO2_1T with a 33-bit first part, so k·_PIO2_1 is exact
# and θ - k·_PIO2_1 too for |k| < 2^20; the absolute error of r stays ~1e-20 (we need absolute,
# not relative, accuracy near multiples of π/2, so fdlibm's third part is not needed).
_TWO_OVER_PI = 6.36619772367581382433e-01
_PIO2_1 = 1.57079632673412561417e00
_PIO2_1T = 6.07710050650619224932e-11
_S1, _S2, _S3 = 1.58969099521155010221e-10, -2.50507602534068634195e-08, 2.75573137070700676789e-06
_S4, _S5, _S6 = -1.98412698298579493134e-04, 8.33333333332248946124e-03, -1.66666666666666324348e-01
_C1, _C2, _C3 = -1.13596475577881948265e-11, 2.08757232129817482790e-09, -2.75573143513906633035e-07
_C4, _C5, _C6 = 2.48015872894767294178e-05, -1.38888888888741095749e-03, 4.16666666666666019037e-02

_JIT = dict(cache=True, nogil=True, boundscheck=False, error_model="numpy")

#: columns of the per-joint integer table
J_QINDEX, J_KIND, J_PARENT = 0, 1, 2
#: columns of the per-joint float table: multiplier, offset, then CZ_j[:3, :4] row-major
J_MULT, J_OFFSET, J_CZ = 0, 1, 2


@nb.njit(**_JIT)
def _sincos_row(th, s, c, m):
    """sin and cos of ``th[:m]`` into ``s[:m]``, ``c[:m]`` (vectorised polynomial, libm beyond range)."""
    for i in range(m):
        x = th[i]
        k = np.rint(x * _TWO_OVER_PI)
        r = (x - k * _PIO2_1) - k * _PIO2_1T
        z = r * r
        sr = r + r * z * (_S6 + z * (_S5 + z * (_S4 + z * (_S3 + z * (_S2 + z * _S1)))))
        cr = 1.0 - 0.5 * z + z * z * (_C6 + z * (_C5 + z * (_C4 + z * (_C3 + z * (_C2 + z * _C1)))))
        q = np.int64(k) & 3
        A = abs(q - 2.0) - 1.0  # cos(q π/2)
        B = 1.0 - abs(q - 1.0)  # sin(q π/2)
        s[i] = A * sr + B * cr
        c[i] = A * cr - B * sr
    for i in range(m):  # rare: huge or non-finite arguments
        x = th[i]
        if not abs(x) <= SINCOS_MAX_ARG:
            s[i] = math.sin(x)
            c[i] = math.cos(x)


@nb.njit(**_JIT)
def sincos(th, s, c):
    """sin and cos of a 1-D float64 array into ``s`` and ``c`` (the kernel's own; for tests)."""
    _sincos_row(th, s, c, th.shape[0])


@nb.njit(**_JIT)
def _scratch(n, chunk):
    """Frames F (n, 12, w) and joint values, sines, cosines W (3, n, w) of one chunk (padded rows)."""
    w = chunk + ROW_PAD
    return np.empty((n, 12, w)), np.empty((3, n, w))


@nb.njit(**_JIT)
def _chunk_frames(Q, a, m, joints, jint, jflt, F, W):
    """θ, sin θ, cos θ and the axis frame of each of ``joints`` (parents first) for
    configurations ``a .. a + m`` of Q."""
    for jj in range(joints.shape[0]):
        j = joints[jj]
        col = jint[j, J_QINDEX]
        mu = jflt[j, J_MULT]
        off = jflt[j, J_OFFSET]
        th, s, c = W[0, j], W[1, j], W[2, j]
        for i in range(m):
            th[i] = Q[a + i, col] * mu + off
        _sincos_row(th, s, c, m)
        _joint_frames(F, j, jint[j, J_PARENT], jint[j, J_KIND] == REVOLUTE, jflt[j], s, c, th, m)


@nb.njit(**_JIT)
def fk(Q, jint, jflt, order, lj, D, out, chunk):
    """Poses of the requested links for every configuration.

    Q: (N, dof) joint values. jint: (n, 3) int64 q_index, kind (0 revolute, 1 prismatic),
    parent (-1 at the root). jflt: (n, 14) multiplier, offset, CZ_j[:3, :4]. order: joints to
    compute, parents first. lj: (L',) frame each output hangs from (-1: constant pose).
    D: (L', 4, 4) constant right factor (G_j^-1 M_L, or M_L when lj < 0; last row 0 0 0 1).
    out: (N, L', 16) row-major poses, written. chunk: configurations per pass.
    """
    N = Q.shape[0]
    F, W = _scratch(jint.shape[0], chunk)
    for a in range(0, N, chunk):
        m = min(chunk, N - a)
        _chunk_frames(Q, a, m, order, jint, jflt, F, W)
        for i in range(m):
            _poses_row(F, i, lj, D, out[a + i])
    return out


@nb.njit(inline="always", **_JIT)
def _poses_row(F, i, lj, D, row):
    """The poses (L', 16) of configuration ``i`` of the chunk's frames ``F``, into ``row``."""
    for k in range(lj.shape[0]):
        o = row[k]
        j = lj[k]
        if j < 0:
            for e in range(16):
                o[e] = D[k, e // 4, e % 4]
            continue
        Fj = F[j]
        for r in range(3):
            f0 = Fj[4 * r, i]
            f1 = Fj[4 * r + 1, i]
            f2 = Fj[4 * r + 2, i]
            f3 = Fj[4 * r + 3, i]
            o[4 * r] = f0 * D[k, 0, 0] + f1 * D[k, 1, 0] + f2 * D[k, 2, 0]
            o[4 * r + 1] = f0 * D[k, 0, 1] + f1 * D[k, 1, 1] + f2 * D[k, 2, 1]
            o[4 * r + 2] = f0 * D[k, 0, 2] + f1 * D[k, 1, 2] + f2 * D[k, 2, 2]
            o[4 * r + 3] = f0 * D[k, 0, 3] + f1 * D[k, 1, 3] + f2 * D[k, 2, 3] + f3
        o[12] = 0.0
        o[13] = 0.0
        o[14] = 0.0
        o[15] = 1.0


@nb.njit(**_JIT)
def _joint_frames(F, j, p, revolute, jf, s, c, th, m):
    """``F[j] = F[p] · CZ_j · Z(θ)`` for ``m`` configurations (``F[p]`` = I when ``p < 0``)."""
    Fj = F[j]
    if p < 0:
        for r in range(3):
            x = jf[J_CZ + 4 * r]
            y = jf[J_CZ + 4 * r + 1]
            z = jf[J_CZ + 4 * r + 2]
            t = jf[J_CZ + 4 * r + 3]
            o0 = Fj[4 * r]
            o1 = Fj[4 * r + 1]
            o2 = Fj[4 * r + 2]
            o3 = Fj[4 * r + 3]
            for i in range(m):
                if revolute:
                    o0[i] = c[i] * x + s[i] * y
                    o1[i] = c[i] * y - s[i] * x
                    o3[i] = t
                else:
                    o0[i] = x
                    o1[i] = y
                    o3[i] = t + th[i] * z
                o2[i] = z
        return
    Fp = F[p]
    c00, c01, c02, c03 = jf[J_CZ], jf[J_CZ + 1], jf[J_CZ + 2], jf[J_CZ + 3]
    c10, c11, c12, c13 = jf[J_CZ + 4], jf[J_CZ + 5], jf[J_CZ + 6], jf[J_CZ + 7]
    c20, c21, c22, c23 = jf[J_CZ + 8], jf[J_CZ + 9], jf[J_CZ + 10], jf[J_CZ + 11]
    for r in range(3):
        p0 = Fp[4 * r]
        p1 = Fp[4 * r + 1]
        p2 = Fp[4 * r + 2]
        p3 = Fp[4 * r + 3]
        o0 = Fj[4 * r]
        o1 = Fj[4 * r + 1]
        o2 = Fj[4 * r + 2]
        o3 = Fj[4 * r + 3]
        if revolute:
            for i in range(m):
                a0 = p0[i]
                a1 = p1[i]
                a2 = p2[i]
                x = a0 * c00 + a1 * c10 + a2 * c20
                y = a0 * c01 + a1 * c11 + a2 * c21
                o0[i] = c[i] * x + s[i] * y  # x' = c x + s y
                o1[i] = c[i] * y - s[i] * x  # y' = c y - s x
                o2[i] = a0 * c02 + a1 * c12 + a2 * c22
                o3[i] = a0 * c03 + a1 * c13 + a2 * c23 + p3[i]
        else:
            for i in range(m):
                a0 = p0[i]
                a1 = p1[i]
                a2 = p2[i]
                z = a0 * c02 + a1 * c12 + a2 * c22
                o0[i] = a0 * c00 + a1 * c10 + a2 * c20
                o1[i] = a0 * c01 + a1 * c11 + a2 * c21
                o2[i] = z
                o3[i] = a0 * c03 + a1 * c13 + a2 * c23 + p3[i] + th[i] * z  # t' = t + θ z


@nb.njit(inline="always", **_JIT)
def joint_column(Fj, i, revolute, ox, oy, oz):
    """A joint's Jacobian column ``(v, ω)`` at the point ``o`` (world axes), from its axis frame
    ``Fj`` (configuration ``i`` of a chunk): ``(ω × (o - p), ω)`` for a revolute joint (``p`` on
    the axis), ``(axis, 0)`` for a prismatic one."""
    wx, wy, wz = Fj[2, i], Fj[6, i], Fj[10, i]  # the joint axis, world
    if revolute:
        dx, dy, dz = ox - Fj[3, i], oy - Fj[7, i], oz - Fj[11, i]
        return wy * dz - wz * dy, wz * dx - wx * dz, wx * dy - wy * dx, wx, wy, wz
    return wx, wy, wz, 0.0, 0.0, 0.0


@nb.njit(**_JIT)
def zero(a):
    """Fill a 1-D float64 array with zeros (without the GIL, so threads zero their own rows)."""
    for i in range(a.shape[0]):
        a[i] = 0.0


#: Jacobian references (codes of the compiled kernel)
REF_WORLD, REF_LOCAL_WORLD_ALIGNED, REF_LOCAL = 0, 1, 2


@nb.njit(**_JIT)
def jacobian(Q, jint, jflt, path, D, ref, J, chunk):
    """Jacobians (N, 6, dof), linear rows first, of the link whose pose is ``F_last · D``.

    path: (k,) the moving joints from the root to the link (a chain, root first); D: (4, 4)
    the link's constant factor ``G_last^-1 M_L``; ref: REF_WORLD (twist at the world
    origin, world axes), REF_LOCAL_WORLD_ALIGNED (velocity of the link origin, world axes)
    or REF_LOCAL (the same in the link's axes). J must be zeros: each joint's column is
    *added* to its q column, times its multiplier (mimic joints share their leader's).
    """
    N = Q.shape[0]
    k = path.shape[0]
    if k == 0:
        return J
    F, W = _scratch(jint.shape[0], chunk)
    for a in range(0, N, chunk):
        m = min(chunk, N - a)
        _chunk_frames(Q, a, m, path, jint, jflt, F, W)
        for i in range(m):
            _jacobian_row(F, i, path, jint, jflt, D, ref, J[a + i])
    return J


@nb.njit(inline="always", **_JIT)
def _link_frame(Fl, i, D, ref):
    """What a Jacobian row needs of the link's pose ``Fl[:, i] · D``: its origin ``o`` (zeros for
    ``world``) and, for ``local``, its rotation ``R`` row by row (zeros otherwise)."""
    ox = oy = oz = 0.0
    if ref != REF_WORLD:
        ox = Fl[0, i] * D[0, 3] + Fl[1, i] * D[1, 3] + Fl[2, i] * D[2, 3] + Fl[3, i]
        oy = Fl[4, i] * D[0, 3] + Fl[5, i] * D[1, 3] + Fl[6, i] * D[2, 3] + Fl[7, i]
        oz = Fl[8, i] * D[0, 3] + Fl[9, i] * D[1, 3] + Fl[10, i] * D[2, 3] + Fl[11, i]
    r00 = r01 = r02 = r10 = r11 = r12 = r20 = r21 = r22 = 0.0
    if ref == REF_LOCAL:
        f00, f01, f02 = Fl[0, i], Fl[1, i], Fl[2, i]
        f10, f11, f12 = Fl[4, i], Fl[5, i], Fl[6, i]
        f20, f21, f22 = Fl[8, i], Fl[9, i], Fl[10, i]
        r00 = f00 * D[0, 0] + f01 * D[1, 0] + f02 * D[2, 0]
        r01 = f00 * D[0, 1] + f01 * D[1, 1] + f02 * D[2, 1]
        r02 = f00 * D[0, 2] + f01 * D[1, 2] + f02 * D[2, 2]
        r10 = f10 * D[0, 0] + f11 * D[1, 0] + f12 * D[2, 0]
        r11 = f10 * D[0, 1] + f11 * D[1, 1] + f12 * D[2, 1]
        r12 = f10 * D[0, 2] + f11 * D[1, 2] + f12 * D[2, 2]
        r20 = f20 * D[0, 0] + f21 * D[1, 0] + f22 * D[2, 0]
        r21 = f20 * D[0, 1] + f21 * D[1, 1] + f22 * D[2, 1]
        r22 = f20 * D[0, 2] + f21 * D[1, 2] + f22 * D[2, 2]
    return ox, oy, oz, r00, r01, r02, r10, r11, r12, r20, r21, r22


@nb.njit(inline="always", **_JIT)
def _path_columns(F, Fl, i, path, jint, jflt, cols, D, ref, Ji):
    """Add the columns of the joints of ``path`` for configuration ``i`` of the chunk's frames ``F``
    into ``Ji``, joint j's into column ``cols[j]`` times its multiplier, for the link whose pose is
    ``Fl · D``; returns that link's frame (:func:`_link_frame`)."""
    frame = _link_frame(Fl, i, D, ref)
    # the link's origin o and rotation R = R_world_L (F_last · D)
    ox, oy, oz, r00, r01, r02, r10, r11, r12, r20, r21, r22 = frame
    for jj in range(path.shape[0]):
        j = path[jj]
        vx, vy, vz, ax, ay, az = joint_column(F[j], i, jint[j, J_KIND] == REVOLUTE, ox, oy, oz)
        if ref == REF_LOCAL:  # R^T v: component c = (column c of R) · v
            vx, vy, vz = (r00 * vx + r10 * vy + r20 * vz, r01 * vx + r11 * vy + r21 * vz,
                          r02 * vx + r12 * vy + r22 * vz)
            ax, ay, az = (r00 * ax + r10 * ay + r20 * az, r01 * ax + r11 * ay + r21 * az,
                          r02 * ax + r12 * ay + r22 * az)
        col = cols[j]
        mu = jflt[j, J_MULT]
        Ji[0, col] += mu * vx
        Ji[1, col] += mu * vy
        Ji[2, col] += mu * vz
        Ji[3, col] += mu * ax
        Ji[4, col] += mu * ay
        Ji[5, col] += mu * az
    return frame


@nb.njit(inline="always", **_JIT)
def _jacobian_row(F, i, path, jint, jflt, D, ref, Ji):
    """Add the Jacobian (6, dof) of configuration ``i`` of the chunk's frames ``F`` into ``Ji``
    (the link's pose is ``F[path[-1]] · D``)."""
    _path_columns(F, F[path[path.shape[0] - 1]], i, path, jint, jflt, jint[:, J_QINDEX], D, ref, Ji)


# ---------------------------------------------------------------------- a floating root
# A model whose only multi-dof joint is a floating joint at its root (``engine/rooted.py``): the
# sub-tree below it is an ordinary PoE model, computed by the same frame steps with one more frame,
# ``F[n] = O · X(q_b)`` per configuration (``O`` the joint's origin, ``X`` its motion from the 7
# entries ``x, y, z, qx, qy, qz, qw`` at ``q[qb]``), which the sub-tree's root joints hang from
# (their parent entry is ``n`` instead of -1) and the links no sub-tree joint moves too (``lj = n``,
# ``D = M_L``). So every frame, pose and Jacobian column comes out in the world frame directly.


@nb.njit(**_JIT)
def _base_frames(Q, a, m, qb, O, Fb):
    """``Fb[:, i] = O · X(q)`` (rows ``4r + c``) for configurations ``a .. a + m`` of Q: the rotation of
    the quaternion ``q[qb + 3 : qb + 7]`` (x, y, z, w; Eigen's formula) and the position ``q[qb : qb + 3]``."""
    for i in range(m):
        row = Q[a + i]
        px, py, pz = row[qb], row[qb + 1], row[qb + 2]
        x, y, z, w = row[qb + 3], row[qb + 4], row[qb + 5], row[qb + 6]
        x00 = 1 - 2 * (y * y + z * z)
        x01 = 2 * (x * y - w * z)
        x02 = 2 * (x * z + w * y)
        x10 = 2 * (x * y + w * z)
        x11 = 1 - 2 * (x * x + z * z)
        x12 = 2 * (y * z - w * x)
        x20 = 2 * (x * z - w * y)
        x21 = 2 * (y * z + w * x)
        x22 = 1 - 2 * (x * x + y * y)
        for r in range(3):
            o0, o1, o2, o3 = O[r, 0], O[r, 1], O[r, 2], O[r, 3]
            Fb[4 * r, i] = o0 * x00 + o1 * x10 + o2 * x20
            Fb[4 * r + 1, i] = o0 * x01 + o1 * x11 + o2 * x21
            Fb[4 * r + 2, i] = o0 * x02 + o1 * x12 + o2 * x22
            Fb[4 * r + 3, i] = o0 * px + o1 * py + o2 * pz + o3


@nb.njit(inline="always", **_JIT)
def _rooted_frames(Q, a, chunk, qb, O, joints, jint, jflt, F, W):
    """The frames of the chunk of configurations from ``a`` (at most ``chunk``) of a model on a
    floating root: the root's child ``F[n] = O · X(q[qb:qb+7])`` (:func:`_base_frames`), then
    ``joints`` (:func:`_chunk_frames`); returns the chunk's size."""
    m = min(chunk, Q.shape[0] - a)
    _base_frames(Q, a, m, qb, O, F[jint.shape[0]])
    _chunk_frames(Q, a, m, joints, jint, jflt, F, W)
    return m


@nb.njit(**_JIT)
def fk_rooted(Q, jint, jflt, order, lj, D, out, chunk, qb, O):
    """:func:`fk` of a model on a floating root: Q (N, nq) the whole configuration (``jint``'s q
    indices point into it), frame ``n = len(jint)`` the floating joint's child (``O · X(q[qb:qb+7])``);
    ``lj`` may name it (``D = M_L``), or be -1 for a constant pose ``D``."""
    F, W = _scratch(jint.shape[0] + 1, chunk)
    for a in range(0, Q.shape[0], chunk):
        m = _rooted_frames(Q, a, chunk, qb, O, order, jint, jflt, F, W)
        for i in range(m):
            _poses_row(F, i, lj, D, out[a + i])
    return out


@nb.njit(**_JIT)
def jacobian_rooted(Q, jint, jflt, vcol, path, D, ref, J, chunk, qb, vb, O):
    """:func:`jacobian` of a link of a model on a floating root (frames as :func:`fk_rooted`): J
    (N, 6, nv), every entry written. The path's joints add their columns to ``vcol[j]`` (their
    leader's velocity entry), the floating joint's six columns ``vb .. vb + 6`` are those of its
    child frame ``B = F[n]`` (twist in that frame, linear first): along and about B's axes at B's
    origin. ``path`` may be empty (a link no sub-tree joint moves: its pose is ``B · D``)."""
    n = jint.shape[0]
    F, W = _scratch(n + 1, chunk)
    for a in range(0, Q.shape[0], chunk):
        m = _rooted_frames(Q, a, chunk, qb, O, path, jint, jflt, F, W)
        for i in range(m):
            _rooted_jacobian_row(F, i, n, path, jint, jflt, vcol, D, ref, vb, J[a + i])
    return J


@nb.njit(inline="always", **_JIT)
def _rooted_jacobian_row(F, i, n, path, jint, jflt, vcol, D, ref, vb, Ji):
    """The Jacobian (6, nv) of configuration ``i`` of the chunk into ``Ji`` (see :func:`jacobian_rooted`)."""
    for r in range(6):
        for c in range(Ji.shape[1]):
            Ji[r, c] = 0.0
    k = path.shape[0]
    Fl = F[path[k - 1]] if k > 0 else F[n]
    ox, oy, oz, r00, r01, r02, r10, r11, r12, r20, r21, r22 = _path_columns(F, Fl, i, path, jint, jflt, vcol, D, ref,
                                                                            Ji)
    # the floating joint: translations along B's axes, rotations about them through B's origin
    Fb = F[n]
    bx, by, bz = Fb[3, i], Fb[7, i], Fb[11, i]
    for c in range(3):
        ex, ey, ez = Fb[c, i], Fb[4 + c, i], Fb[8 + c, i]  # column c of R_world_B
        dx, dy, dz = ox - bx, oy - by, oz - bz
        vx, vy, vz = ey * dz - ez * dy, ez * dx - ex * dz, ex * dy - ey * dx
        lx, ly, lz = ex, ey, ez
        ax, ay, az = ex, ey, ez
        if ref == REF_LOCAL:
            lx, ly, lz = (r00 * ex + r10 * ey + r20 * ez, r01 * ex + r11 * ey + r21 * ez,
                          r02 * ex + r12 * ey + r22 * ez)
            vx, vy, vz = (r00 * vx + r10 * vy + r20 * vz, r01 * vx + r11 * vy + r21 * vz,
                          r02 * vx + r12 * vy + r22 * vz)
            ax, ay, az = lx, ly, lz
        Ji[0, vb + c] = lx
        Ji[1, vb + c] = ly
        Ji[2, vb + c] = lz
        Ji[0, vb + 3 + c] = vx
        Ji[1, vb + 3 + c] = vy
        Ji[2, vb + 3 + c] = vz
        Ji[3, vb + 3 + c] = ax
        Ji[4, vb + 3 + c] = ay
        Ji[5, vb + 3 + c] = az
