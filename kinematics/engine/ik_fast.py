"""Compiled closed-form inverse kinematics of 6-joint chains, batched over targets: the closed forms
the every-solution IK runs (:func:`kinematics.algorithms.ik_all.all_solutions`).

A chain is given by its zero-configuration axes ``h`` (6, 3) (unit; a prismatic joint's
direction), a point ``r`` (6, 3) on each revolute axis, and the joint kinds; a target by
``G = T M⁻¹`` (the product ``E1(q1) ... E6(q6)`` of the screw exponentials, M the home pose of the
link), so every formula below is on the product's own screws, as a sequence of the subproblems of
:mod:`kinematics.engine.subproblems` on 3-tuples (no array is allocated per target: a few hundred
small arrays per target would cost more than the arithmetic). Each kernel writes up to
``FAMILY_CANDIDATES`` candidate configurations per target (``width`` > 0 for a chain near the
family: a least-squares branch point becomes two seeds, see :func:`spread`) into ``Q`` (N, C, 6),
``count`` (N,) and their subproblem flags ``flag`` (N, C) (the largest of the subproblems used).
Candidates are *candidates*: the caller polishes them on the real model and keeps only those whose
FK meets the tolerance.

Families (the caller, :mod:`kinematics.algorithms.ik_families`, detects them and brings the chain
into this form, reversing it for a spherical shoulder):

``spherical_wrist``: axes 4, 5, 6 meet at the wrist centre ``c``, so ``G c = E1 E2 E3 c`` (the
position part) and ``R(h4, q4) R(h5, q5) R(h6, q6) = (R1 R2 R3)ᵀ R_G`` (the orientation part:
subproblem 2 for q4, q5 on ``h6``, subproblem 1 for q6). The position part, by ``position``:

- ``POS_PARALLEL_23`` (axes 2 ∥ 3; Puma, KUKA KR, ABB): rotations about h2 keep the height along
  h2, so subproblem 4 gives q1, subproblem 3 (the distance to axis 2's point) q3, subproblem 1 q2;
- ``POS_INTERSECT_12`` (axes 1, 2 meet at ``o``; 7-dof arms with a locked joint): the distance
  ``|x − o|`` is kept by joints 1, 2, so subproblem 3 gives q3 and subproblem 2 q1, q2;
- ``POS_INTERSECT_12_PRISMATIC`` (the same with a prismatic joint 3; Stanford arm): a quadratic in q3;
- ``POS_PARALLEL_12`` (axes 1 ∥ 2): subproblem 4 for q3 (the height along h1), subproblem 3 q2,
  subproblem 1 q1;
- ``POS_SEARCH`` (a general 3R positioning arm): a bracketing search over q1
  (:func:`spherical_wrist_search`).

``three_parallel`` (axes 2 ∥ 3 ∥ 4, axes 5, 6 meet at ``c``; UR): the height of ``E1⁻¹ G c``
along h2 gives q1 (subproblem 4), ``h2ᵀ R1ᵀ R_G h6 = h2ᵀ R(h5, q5) h6`` q5 (subproblem 4), then q6
(subproblem 1), the sum of the parallel angles (subproblem 1) and the planar 2R (subproblems 3, 1).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from .ik import rotation_log
from .ik_polish import close_rows, damped_step
from .subproblems import (EXACT, LEAST_SQUARES, add, cross, dot, norm, rotate, rotate_cs, scale, sp1, sp1_cs, sp2_cs,
                          sp3, sp4, sub, vec)

_JIT = dict(cache=True, nogil=True, boundscheck=False, error_model="numpy")

#: the largest candidate array a family kernel is given (the bracketing search's bound)
MAX_CANDIDATES = 16
POS_PARALLEL_23, POS_INTERSECT_12, POS_INTERSECT_12_PRISMATIC, POS_PARALLEL_12 = 0, 1, 2, 3


@nb.njit(inline="always", **_JIT)
def mat(G, p):
    """``G[:3, :3] p``."""
    return (G[0, 0] * p[0] + G[0, 1] * p[1] + G[0, 2] * p[2], G[1, 0] * p[0] + G[1, 1] * p[1] + G[1, 2] * p[2],
            G[2, 0] * p[0] + G[2, 1] * p[1] + G[2, 2] * p[2])


@nb.njit(inline="always", **_JIT)
def matT(G, p):
    """``G[:3, :3]ᵀ p``."""
    return (G[0, 0] * p[0] + G[1, 0] * p[1] + G[2, 0] * p[2], G[0, 1] * p[0] + G[1, 1] * p[1] + G[2, 1] * p[2],
            G[0, 2] * p[0] + G[1, 2] * p[1] + G[2, 2] * p[2])




@nb.njit(inline="always", **_JIT)
def spread(ta, tb, n, flag, width):
    """A least-squares branch point as two seeds ``φ ± width`` (``width`` > 0, near families)."""
    if flag == LEAST_SQUARES and n == 1 and width > 0.0:
        return ta - width, ta + width, 2
    return ta, tb, n


@nb.njit(inline="always", **_JIT)
def sp3_seeds(p1, p2, k, d, width):
    """:func:`sp3` with a least-squares point as two seeds (:func:`spread`): (θa, θb, count, flag)."""
    (ta, tb), n, flag = sp3(p1, p2, k, d)
    ta, tb, n = spread(ta, tb, n, flag, width)
    return ta, tb, n, flag


@nb.njit(inline="always", **_JIT)
def sp4_seeds(h, p, k, d, width):
    """:func:`sp4` with a least-squares point as two seeds (:func:`spread`): (θa, θb, count, flag)."""
    (ta, tb), n, flag = sp4(h, p, k, d)
    ta, tb, n = spread(ta, tb, n, flag, width)
    return ta, tb, n, flag


@nb.njit(inline="always", **_JIT)
def about(k, o, theta, p):
    """The point ``p`` turned by θ about the line through ``o`` along the unit axis ``k``."""
    return add(o, rotate(k, theta, sub(p, o)))


@nb.njit(inline="always", **_JIT)
def about_cs(k, o, c, s, p):
    """:func:`about` from ``c = cos θ``, ``s = sin θ``."""
    return add(o, rotate_cs(k, c, s, sub(p, o)))


@nb.njit(inline="always", **_JIT)
def perpendicular(k):
    i = 0
    if abs(k[1]) < abs(k[i]):
        i = 1
    if abs(k[2]) < abs(k[i]):
        i = 2
    e = (1.0 if i == 0 else 0.0, 1.0 if i == 1 else 0.0, 1.0 if i == 2 else 0.0)
    u = cross(k, e)
    return scale(1.0 / norm(u), u)


#: the most candidates :func:`three_parallel` and :func:`spherical_wrist` give a target: three
#: subproblems in turn, each with at most two solutions (or two seeds)
FAMILY_CANDIDATES = 8


@nb.njit(inline="always", **_JIT)
def _store(Q, flag, t, n, q1, q2, q3, q4, q5, q6, f):
    Q[t, n, 0], Q[t, n, 1], Q[t, n, 2] = q1, q2, q3
    Q[t, n, 3], Q[t, n, 4], Q[t, n, 5] = q4, q5, q6
    flag[t, n] = f


@nb.njit(**_JIT)
def three_parallel(G, h_, r_, c_, width, Q, count, flag):
    """Candidates of the three-parallel family (axes 2 ∥ 3 ∥ 4, axes 5, 6 meeting at ``c``) for targets
    ``G`` (N, 4, 4) into ``Q``, ``count``, ``flag``."""
    h0, h1, h2, h3, h4, h5 = vec(h_[0]), vec(h_[1]), vec(h_[2]), vec(h_[3]), vec(h_[4]), vec(h_[5])
    r0, r1, r2, r3 = vec(r_[0]), vec(r_[1]), vec(r_[2]), vec(r_[3])
    c = vec(c_)
    s3 = 1.0 if dot(h1, h2) > 0 else -1.0
    s4 = 1.0 if dot(h1, h3) > 0 else -1.0
    u = perpendicular(h1)
    for t in range(G.shape[0]):
        g = G[t]
        p = add(mat(g, c), (g[0, 3], g[1, 3], g[2, 3]))
        n = 0
        ta, tb, n1, f1 = sp4_seeds(h1, sub(p, r0), h0, dot(h1, sub(c, r0)), width)
        for i in range(n1):
            q1 = -(ta if i == 0 else tb)
            c1, s1 = math.cos(q1), -math.sin(q1)  # the rotation by −q1 (and by q1: c1, −s1)
            a = rotate_cs(h0, c1, s1, mat(g, h5))
            pp = add(r0, rotate_cs(h0, c1, s1, sub(p, r0)))
            t5a, t5b, n5, f5 = sp4_seeds(h1, h5, h4, dot(h1, a), width)
            for j in range(n5):
                q5 = t5a if j == 0 else t5b
                c5, s5 = math.cos(q5), -math.sin(q5)  # by −q5
                m6, c6, s6, f6 = sp1_cs(rotate_cs(h4, c5, s5, h1), matT(g, rotate_cs(h0, c1, -s1, h1)), h5)
                q6 = -m6  # (the rotation by −q6 = m6: c6, s6)
                # R234 x = R1ᵀ Rd R6ᵀ R5ᵀ x
                Ru = rotate_cs(h0, c1, s1, mat(g, rotate_cs(h5, c6, s6, rotate_cs(h4, c5, s5, u))))
                theta, f234 = sp1(u, Ru, h1)
                Rc = rotate_cs(h0, c1, s1, mat(g, rotate_cs(h5, c6, s6, rotate_cs(h4, c5, s5, sub(c, r3)))))
                p4 = sub(pp, Rc)
                t3a, t3b, n3, f3 = sp3_seeds(sub(r3, r2), sub(r1, r2), h2, norm(sub(p4, r1)), width)
                for k in range(n3):
                    q3 = t3a if k == 0 else t3b
                    x = about(h2, r2, q3, r3)
                    q2, f2 = sp1(sub(x, r1), sub(p4, r1), h1)
                    q4 = s4 * (theta - q2 - s3 * q3)
                    _store(Q, flag, t, n, q1, q2, q3, q4, q5, q6, max(f1, f5, f6, f234, f3, f2))
                    n += 1
        count[t] = n


@nb.njit(**_JIT)
def _wrist_part(out, t, n, g, arm, back3, prismatic3, fpos, axes, u):
    """The orientation part of a spherical wrist for one ``arm = (q1, q2, q3)``: up to two candidates
    at n of ``out = (Q, flag)``. ``back3``: (cos, sin) of the rotations by −q1, −q2, −q3, as the
    position part found them; ``axes``: the six joint axes h0..h5."""
    Q, flag = out
    q1, q2, q3 = arm
    h0, h1, h2, h3, h4, h5 = axes
    c1, s1, c2, s2, c3, s3 = back3

    def back(x):
        y = rotate_cs(h0, c1, s1, x)
        y = rotate_cs(h1, c2, s2, y)
        if not prismatic3:
            y = rotate_cs(h2, c3, s3, y)
        return y
    w6 = back(mat(g, h5))
    (a0, a1), (b0, b1), m, f45, cs = sp2_cs(w6, h5, h3, h4)
    for b in range(m):
        q4 = -(a0 if b == 0 else a1)
        q5 = b0 if b == 0 else b1
        # the rotations by −q4 (= θ1 of subproblem 2) and −q5, from its cosines and sines
        c4, s4 = (cs[0], cs[1]) if b == 0 else (cs[2], cs[3])
        c5, s5 = (cs[4], -cs[5]) if b == 0 else (cs[6], -cs[7])
        vv = rotate_cs(h4, c5, s5, rotate_cs(h3, c4, s4, back(mat(g, u))))
        q6, f6 = sp1(u, vv, h5)
        _store(Q, flag, t, n, q1, q2, q3, q4, q5, q6, max(fpos, f45, f6))
        n += 1
    return n


@nb.njit(**_JIT)
def spherical_wrist(G, h_, r_, prismatic3, c_, position, width, Q, count, flag):
    """Candidates of the spherical-wrist family (the position part by ``position``, ``prismatic3`` for a
    prismatic joint 3) for targets ``G`` (N, 4, 4) into ``Q``, ``count``, ``flag``."""
    h0, h1, h2, h3, h4, h5 = vec(h_[0]), vec(h_[1]), vec(h_[2]), vec(h_[3]), vec(h_[4]), vec(h_[5])
    axes = (h0, h1, h2, h3, h4, h5)
    r0, r1, r2 = vec(r_[0]), vec(r_[1]), vec(r_[2])
    c = vec(c_)
    u = perpendicular(h5)
    for t in range(G.shape[0]):
        g = G[t]
        p = add(mat(g, c), (g[0, 3], g[1, 3], g[2, 3]))
        n = 0
        if position == 0:  # axes 2 ∥ 3
            ta, tb, n1, f1 = sp4_seeds(h1, sub(p, r0), h0, dot(h1, sub(c, r0)), width)
            for i in range(n1):
                q1 = -(ta if i == 0 else tb)
                c1, s1 = math.cos(q1), -math.sin(q1)  # by −q1
                pp = about_cs(h0, r0, c1, s1, p)
                t3a, t3b, n3, f3 = sp3_seeds(sub(c, r2), sub(r1, r2), h2, norm(sub(pp, r1)), width)
                for j in range(n3):
                    q3 = t3a if j == 0 else t3b
                    c3, s3 = math.cos(q3), math.sin(q3)
                    x = about_cs(h2, r2, c3, s3, c)
                    q2, c2, s2, f2 = sp1_cs(sub(x, r1), sub(pp, r1), h1)
                    n = _wrist_part((Q, flag), t, n, g, (q1, q2, q3), (c1, s1, c2, -s2, c3, -s3), prismatic3,
                                    max(f1, f2, f3), axes, u)
        elif position == 1 or position == 2:  # axes 1, 2 meet at o
            o = r0
            d = norm(sub(p, o))
            for j in range(2):
                if position == 1:
                    t3a, t3b, n3, f3 = sp3_seeds(sub(c, r2), sub(o, r2), h2, d, width)
                    if j >= n3:
                        break
                    q3 = t3a if j == 0 else t3b
                    c3, s3 = math.cos(q3), math.sin(q3)
                    x = about_cs(h2, r2, c3, s3, c)
                else:
                    co = sub(c, o)
                    bq = dot(h2, co)
                    disc = bq * bq - (dot(co, co) - d * d)
                    f3 = EXACT
                    if disc < 0.0:
                        disc, f3 = 0.0, LEAST_SQUARES
                    s = math.sqrt(disc)
                    if j == 1 and s == 0.0:
                        break
                    q3 = -bq + s if j == 0 else -bq - s
                    c3, s3 = 1.0, 0.0  # (a prismatic joint 3: no rotation)
                    x = add(c, scale(q3, h2))
                (a0, a1), (b0, b1), m, f2, cs = sp2_cs(sub(p, o), sub(x, o), h0, h1)
                for i in range(m):
                    q1 = -(a0 if i == 0 else a1)
                    q2 = b0 if i == 0 else b1
                    # by −q1 = θ1 of subproblem 2, by −q2 = −θ2
                    back3 = ((cs[0], cs[1], cs[4], -cs[5]) if i == 0 else (cs[2], cs[3], cs[6], -cs[7])) + (c3, -s3)
                    n = _wrist_part((Q, flag), t, n, g, (q1, q2, q3), back3, prismatic3, max(f2, f3), axes, u)
        else:  # axes 1 ∥ 2
            t3a, t3b, n3, f3 = sp4_seeds(h0, sub(c, r2), h2, dot(h0, sub(p, r2)), width)
            for j in range(n3):
                q3 = t3a if j == 0 else t3b
                c3, s3 = math.cos(q3), math.sin(q3)
                x = about_cs(h2, r2, c3, s3, c)
                t2a, t2b, n2, f2 = sp3_seeds(sub(x, r1), sub(r0, r1), h1, norm(sub(p, r0)), width)
                for i in range(n2):
                    q2 = t2a if i == 0 else t2b
                    c2, s2 = math.cos(q2), math.sin(q2)
                    y = about_cs(h1, r1, c2, s2, x)
                    q1, c1, s1, f1 = sp1_cs(sub(y, r0), sub(p, r0), h0)
                    n = _wrist_part((Q, flag), t, n, g, (q1, q2, q3), (c1, -s1, c2, -s2, c3, -s3), prismatic3,
                                    max(f1, f2, f3), axes, u)
        count[t] = n


#: the position part of a spherical wrist on a general 3R arm: a search over q1
POS_SEARCH = 4
#: samples of q1 over a turn (a sign change between two samples is bracketed and refined)
SEARCH_SAMPLES = 1440


@nb.njit(inline="always", **_JIT)
def _branch(q1, p, c, r0, r1, r2, h0, h1, h2, b):
    """Residual of branch b (0, 1) of the position part at q1: the height along axis 2 of the wrist
    centre turned by q3 (subproblem 3: its distance to axis 2's point right) minus the target's."""
    pp = about(h0, r0, -q1, p)
    (ta, tb), n, f = sp3(sub(c, r2), sub(r1, r2), h2, norm(sub(pp, r1)))
    q3 = ta if (b == 0 or n == 1) else tb
    x = about(h2, r2, q3, c)
    return dot(h1, sub(x, r1)) - dot(h1, sub(pp, r1)), q3, pp


@nb.njit(**_JIT)
def spherical_wrist_search(G, h_, r_, c_, samples, Q, count, flag):
    """Candidates of a spherical wrist (axes 4, 5, 6 meet at c) on a general 3R positioning arm.

    ``E1 E2 E3 c = p``: for each q1 the point ``p' = E1⁻¹ p`` must be reached by joints 2, 3.
    Joint 2 keeps the distance to its axis point ``r2`` (subproblem 3 gives the two q3) and the height
    along its axis, so each branch has the residual ``h2·(E3 c − r2) − h2·(p' − r2)`` in q1 (beyond the
    reach of subproblem 3 its least-squares q3 continues it). ``samples`` values of q1 over a turn
    bracket every sign change; bisection refines each to machine precision, then subproblem 1 gives
    q2 and the wrist part q4, q5, q6. A root of even multiplicity (a tangency) or two roots within one
    sample step would be missed; a root in the least-squares continuation is not a solution, and the
    caller's FK check drops it."""
    h0, h1, h2, h3, h4, h5 = vec(h_[0]), vec(h_[1]), vec(h_[2]), vec(h_[3]), vec(h_[4]), vec(h_[5])
    axes = (h0, h1, h2, h3, h4, h5)
    r0, r1, r2 = vec(r_[0]), vec(r_[1]), vec(r_[2])
    c = vec(c_)
    u = perpendicular(h5)
    step = 2.0 * math.pi / samples
    for t in range(G.shape[0]):
        g = G[t]
        p = add(mat(g, c), (g[0, 3], g[1, 3], g[2, 3]))
        n = 0
        for b in range(2):
            a = -math.pi
            fa, _, _ = _branch(a, p, c, r0, r1, r2, h0, h1, h2, b)
            for s in range(1, samples + 1):
                bq = -math.pi + s * step
                fb, _, _ = _branch(bq, p, c, r0, r1, r2, h0, h1, h2, b)
                if fa == 0.0 or (fa < 0.0) != (fb < 0.0):
                    lo, hi, flo = a, bq, fa
                    for _ in range(60):
                        mid = 0.5 * (lo + hi)
                        fm, _, _ = _branch(mid, p, c, r0, r1, r2, h0, h1, h2, b)
                        if (fm < 0.0) == (flo < 0.0) and fm != 0.0:
                            lo, flo = mid, fm
                        else:
                            hi = mid
                    q1 = 0.5 * (lo + hi)
                    _, q3, pp = _branch(q1, p, c, r0, r1, r2, h0, h1, h2, b)
                    x = about(h2, r2, q3, c)
                    q2, f2 = sp1(sub(x, r1), sub(pp, r1), h1)
                    if n + 2 <= Q.shape[1]:
                        back3 = (math.cos(q1), -math.sin(q1), math.cos(q2), -math.sin(q2), math.cos(q3), -math.sin(q3))
                        n = _wrist_part((Q, flag), t, n, g, (q1, q2, q3), back3, False, f2, axes, u)
                a, fa = bq, fb
        count[t] = n


@nb.njit(**_JIT)
def damped_steps(J, e, lam, dq):
    """``dq[i] = (J_iᵀ J_i + λ_i I)⁻¹ J_iᵀ e_i`` for each row i (J (K, m, n), e (K, m), λ (K,) > 0):
    the normal equations by a Cholesky factorisation in plain loops, row by row (the same bits for a
    row alone and in a batch: :func:`~kinematics.engine.ik_polish.damped_step` on each row). A factor
    that is not positive (λ too small for a singular J) gives a zero step."""
    K, n = J.shape[0], J.shape[2]
    A = np.empty((n, n))
    b = np.empty(n)
    for i in range(K):
        damped_step(J[i], e[i], lam[i], A, b, dq[i])


@nb.njit(**_JIT)
def pose_error_rows(F, T, e):
    """``e[i] = (p_T − p_F, log(R_T R_Fᵀ))`` (world axes) for poses F, T (K, 4, 4), row by row."""
    R = np.empty((3, 3))
    out = np.empty(3)
    for i in range(F.shape[0]):
        for a in range(3):
            e[i, a] = T[i, a, 3] - F[i, a, 3]
            for b in range(3):
                R[a, b] = T[i, a, 0] * F[i, b, 0] + T[i, a, 1] * F[i, b, 1] + T[i, a, 2] * F[i, b, 2]
        rotation_log(R, out)
        e[i, 3], e[i, 4], e[i, 5] = out[0], out[1], out[2]


@nb.njit(**_JIT)
def distinct_rows(Q, ok, starts, columns, revolute, tolerance, keep):
    """``keep[i]``: row i of ``Q`` (R, dof) is ``ok`` and no earlier kept row of its group
    (rows ``starts[g]:starts[g + 1]``) is within ``tolerance`` of it in every column of ``columns``
    (revolute columns compared modulo 2π)."""
    for g in range(starts.shape[0] - 1):
        for i in range(starts[g], starts[g + 1]):
            keep[i] = False
            if not ok[i]:
                continue
            dup = False
            for j in range(starts[g], i):
                if not keep[j]:
                    continue
                if close_rows(Q[i], Q[j], columns, revolute, tolerance):
                    dup = True
                    break
            keep[i] = not dup
