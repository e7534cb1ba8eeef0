"""Compiled (numba) link velocities: one pass down the tree per chunk of configurations.

For joint values ``q`` and joint velocities ``qdot`` (both (N, dof)) the kernel computes, for
every requested link, the velocity of its origin and its angular velocity, by propagation
from the root (Craig's outward velocity propagation) on the axis frames of the
FK kernel (:func:`kinematics.engine.compiled._chunk_frames`):

    ω_j = ω_parent + θ̇_j z_j                                    (revolute)
    v_j = v_parent + ω_parent × (o_j - o_parent) (+ θ̇_j z_j      prismatic)
    v_L = v_j + ω_j × (o_L - o_j),  ω_L = ω_j                    (link L hangs from joint j)

``o_j`` and ``z_j`` are the origin and z axis of joint j's axis frame ``F_j`` (a point on the
joint axis and the axis, world coordinates); ``v_j`` is the velocity of ``o_j`` as a point of
the body after joint j. ``θ̇_j = multiplier_j · qdot[q_index_j]`` (a mimic joint follows its
leader). One joint's velocity costs a cross product and an addition, whatever the number of
links below it: a tree of L links costs O(L) per configuration, not O(L · dof) as one Jacobian
product per link would.

Each link's velocity is written in the three references of the Jacobians (twists, linear
part first; ``o``, ``R`` the link's origin and rotation, ``R = R_world_L``):

- ``local_world_aligned``: ``(v_L, ω_L)``, the origin's velocity and the angular velocity in world axes;
- ``world``: ``(v_L + o × ω_L, ω_L)``, the velocity of the body point at the world origin;
- ``local``: ``(R^T v_L, R^T ω_L)``, in the link's own axes.

These equal ``J(q) qdot`` of the three Jacobians (``tests/kinematics/engine/test_velocity.py``).
"""

from __future__ import annotations

import numba as nb
import numpy as np

# the FK kernel's chunk walk and scratch buffers, private to the engine: velocities run the same frames
from .compiled import (J_KIND, J_MULT, J_PARENT, J_QINDEX, REF_LOCAL, REF_LOCAL_WORLD_ALIGNED, REF_WORLD, REVOLUTE,
                       ROW_PAD, _chunk_frames, _scratch)

_JIT = dict(cache=True, nogil=True, boundscheck=False, error_model="numpy")


@nb.njit(**_JIT)
def velocities(Q, Qd, jint, jflt, order, lj, D, out, chunk):
    """Twists of the requested links for every configuration.

    Q, Qd: (N, dof) joint values and velocities. jint, jflt, order, lj, D: as
    :func:`kinematics.engine.compiled.fk` (the link pose is ``F_lj · D``; ``lj < 0``: a link no
    joint moves, velocity zero). out: (3, N, L', 6), every entry written: ``out[REF_*, :, k]``
    the twist of output k in that reference, linear part first (each reference contiguous).
    """
    N = Q.shape[0]
    L = lj.shape[0]
    n = jint.shape[0]
    F, W = _scratch(n, chunk)
    V = np.zeros((n, 6, chunk + ROW_PAD))  # per joint: v_j (3), ω_j (3), world axes
    for a in range(0, N, chunk):
        m = min(chunk, N - a)
        _chunk_frames(Q, a, m, order, jint, jflt, F, W)
        for jj in range(order.shape[0]):
            j = order[jj]
            p = jint[j, J_PARENT]
            col = jint[j, J_QINDEX]
            mu = jflt[j, J_MULT]
            revolute = jint[j, J_KIND] == REVOLUTE
            Fj = F[j]
            Vj = V[j]
            if p < 0:
                for i in range(m):
                    td = mu * Qd[a + i, col]
                    zx, zy, zz = Fj[2, i], Fj[6, i], Fj[10, i]
                    if revolute:
                        Vj[0, i] = 0.0
                        Vj[1, i] = 0.0
                        Vj[2, i] = 0.0
                        Vj[3, i] = td * zx
                        Vj[4, i] = td * zy
                        Vj[5, i] = td * zz
                    else:
                        Vj[0, i] = td * zx
                        Vj[1, i] = td * zy
                        Vj[2, i] = td * zz
                        Vj[3, i] = 0.0
                        Vj[4, i] = 0.0
                        Vj[5, i] = 0.0
                continue
            Fp = F[p]
            Vp = V[p]
            for i in range(m):
                td = mu * Qd[a + i, col]
                wx, wy, wz = Vp[3, i], Vp[4, i], Vp[5, i]
                dx = Fj[3, i] - Fp[3, i]
                dy = Fj[7, i] - Fp[7, i]
                dz = Fj[11, i] - Fp[11, i]
                vx = Vp[0, i] + (wy * dz - wz * dy)
                vy = Vp[1, i] + (wz * dx - wx * dz)
                vz = Vp[2, i] + (wx * dy - wy * dx)
                zx, zy, zz = Fj[2, i], Fj[6, i], Fj[10, i]
                if revolute:
                    wx += td * zx
                    wy += td * zy
                    wz += td * zz
                else:
                    vx += td * zx
                    vy += td * zy
                    vz += td * zz
                Vj[0, i] = vx
                Vj[1, i] = vy
                Vj[2, i] = vz
                Vj[3, i] = wx
                Vj[4, i] = wy
                Vj[5, i] = wz
        for i in range(m):
            lwa_row = out[REF_LOCAL_WORLD_ALIGNED, a + i]
            world_row = out[REF_WORLD, a + i]
            local_row = out[REF_LOCAL, a + i]
            for k in range(L):
                j = lj[k]
                if j < 0:
                    for e in range(6):
                        lwa_row[k, e] = 0.0
                        world_row[k, e] = 0.0
                        local_row[k, e] = 0.0
                    continue
                Fj = F[j]
                Vj = V[j]
                # the link's origin (F_j · D)[:3, 3] and rotation (F_j · D)[:3, :3]
                f00, f01, f02, f03 = Fj[0, i], Fj[1, i], Fj[2, i], Fj[3, i]
                f10, f11, f12, f13 = Fj[4, i], Fj[5, i], Fj[6, i], Fj[7, i]
                f20, f21, f22, f23 = Fj[8, i], Fj[9, i], Fj[10, i], Fj[11, i]
                ox = f00 * D[k, 0, 3] + f01 * D[k, 1, 3] + f02 * D[k, 2, 3] + f03
                oy = f10 * D[k, 0, 3] + f11 * D[k, 1, 3] + f12 * D[k, 2, 3] + f13
                oz = f20 * D[k, 0, 3] + f21 * D[k, 1, 3] + f22 * D[k, 2, 3] + f23
                wx, wy, wz = Vj[3, i], Vj[4, i], Vj[5, i]
                dx, dy, dz = ox - f03, oy - f13, oz - f23
                vx = Vj[0, i] + (wy * dz - wz * dy)
                vy = Vj[1, i] + (wz * dx - wx * dz)
                vz = Vj[2, i] + (wx * dy - wy * dx)
                t = lwa_row[k]
                t[0], t[1], t[2], t[3], t[4], t[5] = vx, vy, vz, wx, wy, wz
                t = world_row[k]
                t[0] = vx + (oy * wz - oz * wy)
                t[1] = vy + (oz * wx - ox * wz)
                t[2] = vz + (ox * wy - oy * wx)
                t[3], t[4], t[5] = wx, wy, wz
                t = local_row[k]
                for c in range(3):  # component c = (column c of R) . v, R = F_j[:3, :3] D[:3, :3]
                    r0 = f00 * D[k, 0, c] + f01 * D[k, 1, c] + f02 * D[k, 2, c]
                    r1 = f10 * D[k, 0, c] + f11 * D[k, 1, c] + f12 * D[k, 2, c]
                    r2 = f20 * D[k, 0, c] + f21 * D[k, 1, c] + f22 * D[k, 2, c]
                    t[c] = r0 * vx + r1 * vy + r2 * vz
                    t[3 + c] = r0 * wx + r1 * wy + r2 * wz
    return out
