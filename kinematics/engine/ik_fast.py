"""The closed forms of :mod:`kinematics.engine.ik_closed` on 3-tuples: no array is allocated per
target (the array forms allocate a few hundred small arrays per target, which costs more than the
arithmetic). The same formulas, the same candidates in the same order; the family tests check both
through :func:`kinematics.algorithms.ik_all.all_solutions`, and ``tests/kinematics/engine`` checks
that the two give the same candidates."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from .ik import rotation_log
from .ik_polish import damped_step
from .subproblems import DEGENERATE, EXACT, LEAST_SQUARES, TANGENT, ZERO, sp2_image

_JIT = dict(cache=True, nogil=True, boundscheck=False, error_model="numpy")


@nb.njit(inline="always", **_JIT)
def v(a):
    return (a[0], a[1], a[2])


@nb.njit(inline="always", **_JIT)
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@nb.njit(inline="always", **_JIT)
def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@nb.njit(inline="always", **_JIT)
def scale(s, a):
    return (s * a[0], s * a[1], s * a[2])


@nb.njit(inline="always", **_JIT)
def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@nb.njit(inline="always", **_JIT)
def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@nb.njit(inline="always", **_JIT)
def norm(a):
    return math.sqrt(dot(a, a))


@nb.njit(inline="always", **_JIT)
def rot(k, theta, p):
    """``R(k, θ) p``."""
    return rot_cs(k, math.cos(theta), math.sin(theta), p)


@nb.njit(inline="always", **_JIT)
def rot_cs(k, c, s, p):
    """``R(k, θ) p`` from ``c = cos θ``, ``s = sin θ`` (a rotation used more than once: its sine and
    cosine once)."""
    kp = dot(k, p)
    kx = cross(k, p)
    w = (1.0 - c) * kp
    return (c * p[0] + s * kx[0] + w * k[0], c * p[1] + s * kx[1] + w * k[1], c * p[2] + s * kx[2] + w * k[2])


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
def trig(A, B, C):
    """(θa, θb, count, flag) of ``A cos θ + B sin θ = C`` (as :func:`~kinematics.engine.subproblems.trig_solve`)."""
    r = math.hypot(A, B)
    sc = max(r, abs(C), 1.0)
    if r <= ZERO * sc:
        return 0.0, 0.0, 1, (DEGENERATE if abs(C) <= ZERO * sc else LEAST_SQUARES)
    phi = math.atan2(B, A)
    x = C / r
    if x >= 1.0 + TANGENT:
        return phi, 0.0, 1, LEAST_SQUARES
    if x <= -1.0 - TANGENT:
        return phi + math.pi, 0.0, 1, LEAST_SQUARES
    if abs(abs(x) - 1.0) <= TANGENT:
        return (phi if x > 0 else phi + math.pi), 0.0, 1, EXACT
    a = math.acos(x)
    return phi + a, phi - a, 2, EXACT


@nb.njit(inline="always", **_JIT)
def sp1_cs(p1, p2, k):
    """(θ, cos θ, sin θ, flag) of subproblem 1, ``R(k, θ) p1 = p2`` (the cosine and sine from the
    same two numbers as θ: a rotation by θ needs no trigonometric call)."""
    kp1, kp2 = dot(k, p1), dot(k, p2)
    a = sub(p1, scale(kp1, k))
    b = sub(p2, scale(kp2, k))
    na, nb_ = norm(a), norm(b)
    sc = max(na, nb_, 1.0)
    if na <= ZERO * sc or nb_ <= ZERO * sc:
        return 0.0, 1.0, 0.0, DEGENERATE
    y, x = dot(k, cross(a, b)), dot(a, b)
    theta = math.atan2(y, x)
    rr = math.sqrt(x * x + y * y)
    c, s = x / rr, y / rr
    if abs(na - nb_) > 1e-9 * sc or abs(kp1 - kp2) > 1e-9 * sc:
        return theta, c, s, LEAST_SQUARES
    return theta, c, s, EXACT


@nb.njit(inline="always", **_JIT)
def sp1(p1, p2, k):
    """(θ, flag) of subproblem 1 (:func:`sp1_cs`)."""
    theta, _, _, flag = sp1_cs(p1, p2, k)
    return theta, flag


@nb.njit(inline="always", **_JIT)
def sp3(p1, p2, k, d):
    kp1, kp2 = dot(k, p1), dot(k, p2)
    a = sub(p1, scale(kp1, k))
    b = sub(p2, scale(kp2, k))
    return trig(2.0 * dot(a, b), 2.0 * dot(cross(k, a), b), dot(a, a) + dot(b, b) + (kp1 - kp2) ** 2 - d * d)


@nb.njit(inline="always", **_JIT)
def sp4(h, p, k, d):
    kp = dot(k, p)
    hk = dot(h, k)
    return trig(dot(h, p) - hk * kp, dot(h, cross(k, p)), d - hk * kp)


@nb.njit(inline="always", **_JIT)
def sp2_cs(p1, p2, k1, k2):
    """(θ1a, θ1b, θ2a, θ2b, count, flag, (cos, sin) of each of the four) of ``R(k1, θ1) p1 = R(k2, θ2) p2``."""
    base, n, g, count, flag = sp2_image(p1, p2, k1, k2)
    if flag == DEGENERATE:
        return 0.0, 0.0, 0.0, 0.0, 1, DEGENERATE, (1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0)
    x = add(base, scale(g, n))
    a0, ca0, sa0, f1 = sp1_cs(p1, x, k1)
    b0, cb0, sb0, f2 = sp1_cs(p2, x, k2)
    if f1 == DEGENERATE or f2 == DEGENERATE:
        flag = DEGENERATE
    a1 = b1 = 0.0
    ca1, sa1, cb1, sb1 = 1.0, 0.0, 1.0, 0.0
    if count == 2:
        x = sub(base, scale(g, n))
        a1, ca1, sa1, f1 = sp1_cs(p1, x, k1)
        b1, cb1, sb1, f2 = sp1_cs(p2, x, k2)
        if f1 == DEGENERATE or f2 == DEGENERATE:
            flag = DEGENERATE
    return a0, a1, b0, b1, count, flag, (ca0, sa0, ca1, sa1, cb0, sb0, cb1, sb1)


@nb.njit(inline="always", **_JIT)
def sp2(p1, p2, k1, k2):
    """(θ1a, θ1b, θ2a, θ2b, count, flag) of ``R(k1, θ1) p1 = R(k2, θ2) p2`` (:func:`sp2_cs`)."""
    a0, a1, b0, b1, count, flag, _ = sp2_cs(p1, p2, k1, k2)
    return a0, a1, b0, b1, count, flag


@nb.njit(inline="always", **_JIT)
def spread(ta, tb, n, flag, width):
    """A least-squares branch point as two seeds ``φ ± width`` (``width`` > 0, near families)."""
    if flag == LEAST_SQUARES and n == 1 and width > 0.0:
        return ta - width, ta + width, 2
    return ta, tb, n


@nb.njit(inline="always", **_JIT)
def sp3_seeds(p1, p2, k, d, width):
    """:func:`sp3` with a least-squares point as two seeds (:func:`spread`): (θa, θb, count, flag)."""
    ta, tb, n, flag = sp3(p1, p2, k, d)
    ta, tb, n = spread(ta, tb, n, flag, width)
    return ta, tb, n, flag


@nb.njit(inline="always", **_JIT)
def sp4_seeds(h, p, k, d, width):
    """:func:`sp4` with a least-squares point as two seeds (:func:`spread`): (θa, θb, count, flag)."""
    ta, tb, n, flag = sp4(h, p, k, d)
    ta, tb, n = spread(ta, tb, n, flag, width)
    return ta, tb, n, flag


@nb.njit(inline="always", **_JIT)
def about(k, o, theta, p):
    """The point ``p`` turned by θ about the line through ``o`` along the unit axis ``k``."""
    return add(o, rot(k, theta, sub(p, o)))


@nb.njit(inline="always", **_JIT)
def about_cs(k, o, c, s, p):
    """:func:`about` from ``c = cos θ``, ``s = sin θ``."""
    return add(o, rot_cs(k, c, s, sub(p, o)))


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
    """As :func:`kinematics.engine.ik_closed.three_parallel`."""
    h0, h1, h2, h3, h4, h5 = v(h_[0]), v(h_[1]), v(h_[2]), v(h_[3]), v(h_[4]), v(h_[5])
    r0, r1, r2, r3 = v(r_[0]), v(r_[1]), v(r_[2]), v(r_[3])
    c = v(c_)
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
            a = rot_cs(h0, c1, s1, mat(g, h5))
            pp = add(r0, rot_cs(h0, c1, s1, sub(p, r0)))
            t5a, t5b, n5, f5 = sp4_seeds(h1, h5, h4, dot(h1, a), width)
            for j in range(n5):
                q5 = t5a if j == 0 else t5b
                c5, s5 = math.cos(q5), -math.sin(q5)  # by −q5
                m6, c6, s6, f6 = sp1_cs(rot_cs(h4, c5, s5, h1), matT(g, rot_cs(h0, c1, -s1, h1)), h5)
                q6 = -m6  # (the rotation by −q6 = m6: c6, s6)
                # R234 x = R1ᵀ Rd R6ᵀ R5ᵀ x
                Ru = rot_cs(h0, c1, s1, mat(g, rot_cs(h5, c6, s6, rot_cs(h4, c5, s5, u))))
                theta, f234 = sp1(u, Ru, h1)
                Rc = rot_cs(h0, c1, s1, mat(g, rot_cs(h5, c6, s6, rot_cs(h4, c5, s5, sub(c, r3)))))
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
def _wrist_part(Q, flag, t, n, g, q1, q2, q3, back3, prismatic3, fpos, h0, h1, h2, h3, h4, h5, u):
    """The orientation part of a spherical wrist for one (q1, q2, q3): up to two candidates at n.
    ``back3``: (cos, sin) of the rotations by −q1, −q2, −q3, as the position part found them."""
    c1, s1, c2, s2, c3, s3 = back3

    def back(x):
        y = rot_cs(h0, c1, s1, x)
        y = rot_cs(h1, c2, s2, y)
        if not prismatic3:
            y = rot_cs(h2, c3, s3, y)
        return y
    w6 = back(mat(g, h5))
    a0, a1, b0, b1, m, f45, cs = sp2_cs(w6, h5, h3, h4)
    for b in range(m):
        q4 = -(a0 if b == 0 else a1)
        q5 = b0 if b == 0 else b1
        # the rotations by −q4 (= θ1 of subproblem 2) and −q5, from its cosines and sines
        c4, s4 = (cs[0], cs[1]) if b == 0 else (cs[2], cs[3])
        c5, s5 = (cs[4], -cs[5]) if b == 0 else (cs[6], -cs[7])
        vv = rot_cs(h4, c5, s5, rot_cs(h3, c4, s4, back(mat(g, u))))
        q6, f6 = sp1(u, vv, h5)
        _store(Q, flag, t, n, q1, q2, q3, q4, q5, q6, max(fpos, f45, f6))
        n += 1
    return n


@nb.njit(**_JIT)
def spherical_wrist(G, h_, r_, prismatic3, c_, position, width, Q, count, flag):
    """As :func:`kinematics.engine.ik_closed.spherical_wrist`."""
    h0, h1, h2, h3, h4, h5 = v(h_[0]), v(h_[1]), v(h_[2]), v(h_[3]), v(h_[4]), v(h_[5])
    r0, r1, r2 = v(r_[0]), v(r_[1]), v(r_[2])
    c = v(c_)
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
                    n = _wrist_part(Q, flag, t, n, g, q1, q2, q3, (c1, s1, c2, -s2, c3, -s3), prismatic3,
                                    max(f1, f2, f3), h0, h1, h2, h3, h4, h5, u)
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
                a0, a1, b0, b1, m, f2, cs = sp2_cs(sub(p, o), sub(x, o), h0, h1)
                for i in range(m):
                    q1 = -(a0 if i == 0 else a1)
                    q2 = b0 if i == 0 else b1
                    # by −q1 = θ1 of subproblem 2, by −q2 = −θ2
                    back3 = ((cs[0], cs[1], cs[4], -cs[5]) if i == 0 else (cs[2], cs[3], cs[6], -cs[7])) + (c3, -s3)
                    n = _wrist_part(Q, flag, t, n, g, q1, q2, q3, back3, prismatic3, max(f2, f3), h0, h1, h2, h3, h4,
                                    h5, u)
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
                    n = _wrist_part(Q, flag, t, n, g, q1, q2, q3, (c1, -s1, c2, -s2, c3, -s3), prismatic3,
                                    max(f1, f2, f3), h0, h1, h2, h3, h4, h5, u)
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
    ta, tb, n, f = sp3(sub(c, r2), sub(r1, r2), h2, norm(sub(pp, r1)))
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
    h0, h1, h2, h3, h4, h5 = v(h_[0]), v(h_[1]), v(h_[2]), v(h_[3]), v(h_[4]), v(h_[5])
    r0, r1, r2 = v(r_[0]), v(r_[1]), v(r_[2])
    c = v(c_)
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
                        n = _wrist_part(Q, flag, t, n, g, q1, q2, q3, back3, False, f2, h0, h1, h2, h3, h4, h5, u)
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
