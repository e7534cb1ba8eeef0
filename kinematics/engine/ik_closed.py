"""Compiled closed-form inverse kinematics of 6-joint chains, batched over targets.

A chain is given by its zero-configuration axes ``h`` (6, 3) (unit; a prismatic joint's
direction), a point ``r`` (6, 3) on each revolute axis, and the joint kinds; a target by
``G = T M⁻¹`` (the product ``E1(q1) ... E6(q6)`` of the screw exponentials, M the home pose of the
link), so every formula below is on the product's own screws. Each kernel writes up to
``MAX_CANDIDATES`` candidate configurations per target (``spread`` > 0 for a chain near the family: a
least-squares branch point becomes two seeds, see :func:`_spread`) (``Q`` (N, 16, 6), ``count`` (N,)) and
their subproblem flags (``flag`` (N, 16): the largest of the subproblems used, see
:mod:`kinematics.engine.subproblems`). Candidates are *candidates*: the caller polishes them on the
real model and keeps only those whose FK meets the tolerance.

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
  subproblem 1 q1.

``three_parallel`` (axes 2 ∥ 3 ∥ 4, axes 5, 6 meet at ``c``; UR): the height of ``E1⁻¹ G c``
along h2 gives q1 (subproblem 4), ``h2ᵀ R1ᵀ R_G h6 = h2ᵀ R(h5, q5) h6`` q5 (subproblem 4), then q6
(subproblem 1), the sum of the parallel angles (subproblem 1) and the planar 2R (subproblems 3, 1).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from .ik_polish import close_rows
from .subproblems import DEGENERATE, EXACT, cross, dot, rot, rotate, sp1, sp2, sp3, sp4

_JIT = dict(cache=True, nogil=True, boundscheck=False, error_model="numpy")

MAX_CANDIDATES = 16
POS_PARALLEL_23, POS_INTERSECT_12, POS_INTERSECT_12_PRISMATIC, POS_PARALLEL_12 = 0, 1, 2, 3


@nb.njit(**_JIT)
def _sub(a, b):
    out = np.empty(3)
    for i in range(3):
        out[i] = a[i] - b[i]
    return out


@nb.njit(**_JIT)
def _add(a, b):
    out = np.empty(3)
    for i in range(3):
        out[i] = a[i] + b[i]
    return out


@nb.njit(**_JIT)
def _norm(a):
    return math.sqrt(dot(a, a))


@nb.njit(**_JIT)
def _perpendicular(k):
    """A unit vector perpendicular to the unit vector ``k``."""
    a = np.zeros(3)
    i = 0
    if abs(k[1]) < abs(k[i]):
        i = 1
    if abs(k[2]) < abs(k[i]):
        i = 2
    a[i] = 1.0
    u = cross(k, a)
    n = _norm(u)
    for j in range(3):
        u[j] /= n
    return u


@nb.njit(**_JIT)
def _point(G, x):
    """``G x`` for a point x (3,) and a 4x4 transform G."""
    out = np.empty(3)
    for i in range(3):
        out[i] = G[i, 0] * x[0] + G[i, 1] * x[1] + G[i, 2] * x[2] + G[i, 3]
    return out


@nb.njit(**_JIT)
def _spread(sols, n, flag, spread):
    """A least-squares answer φ of a branching subproblem as the two seeds φ ± spread (spread > 0):
    on a chain *near* the family, the real solutions may be a close pair where the ideal chain has
    none (a target by the edge of the reach), and Newton from φ alone would find one of the pair."""
    if flag == 1 and n == 1 and spread > 0.0:
        out = np.empty(2)
        out[0] = sols[0] - spread
        out[1] = sols[0] + spread
        return out, 2
    return sols, n


@nb.njit(**_JIT)
def _position_part(p, h, r, c, position, out, flags, spread):
    """The (q1, q2, q3) with ``E1 E2 E3 c = p`` into ``out`` (4, 3); returns their number."""
    n = 0
    if position == POS_PARALLEL_23:
        t1, n1, f1 = sp4(h[1], _sub(p, r[0]), h[0], dot(h[1], _sub(c, r[0])))
        t1, n1 = _spread(t1, n1, f1, spread)
        for i in range(n1):
            q1 = -t1[i]
            pp = _add(r[0], rotate(h[0], -q1, _sub(p, r[0])))
            t3, n3, f3 = sp3(_sub(c, r[2]), _sub(r[1], r[2]), h[2], _norm(_sub(pp, r[1])))
            t3, n3 = _spread(t3, n3, f3, spread)
            for j in range(n3):
                x = _add(r[2], rotate(h[2], t3[j], _sub(c, r[2])))
                q2, f2 = sp1(_sub(x, r[1]), _sub(pp, r[1]), h[1])
                out[n, 0], out[n, 1], out[n, 2] = q1, q2, t3[j]
                flags[n] = max(f1, f2, f3)
                n += 1
    elif position == POS_INTERSECT_12 or position == POS_INTERSECT_12_PRISMATIC:
        o = r[0]
        d = _norm(_sub(p, o))
        xs = np.empty((2, 3))
        q3s = np.empty(2)
        fs = np.zeros(2, dtype=np.int64)
        m = 0
        if position == POS_INTERSECT_12:
            t3, n3, f3 = sp3(_sub(c, r[2]), _sub(o, r[2]), h[2], d)
            t3, n3 = _spread(t3, n3, f3, spread)
            for j in range(n3):
                xs[m] = _add(r[2], rotate(h[2], t3[j], _sub(c, r[2])))
                q3s[m] = t3[j]
                fs[m] = f3
                m += 1
        else:
            co = _sub(c, o)
            b = dot(h[2], co)
            disc = b * b - (dot(co, co) - d * d)
            flag = EXACT
            if disc < 0.0:
                disc = 0.0
                flag = 1
            s = math.sqrt(disc)
            roots = np.array([-b + s, -b - s])
            for j in range(1 if s == 0.0 else 2):
                q3s[m] = roots[j]
                for i in range(3):
                    xs[m, i] = c[i] + roots[j] * h[2, i]
                fs[m] = flag
                m += 1
        for j in range(m):
            t1, t2, n2, f2 = sp2(_sub(p, o), _sub(xs[j], o), h[0], h[1])
            for i in range(n2):
                out[n, 0], out[n, 1], out[n, 2] = -t1[i], t2[i], q3s[j]
                flags[n] = max(f2, fs[j])
                n += 1
    else:  # POS_PARALLEL_12
        t3, n3, f3 = sp4(h[0], _sub(c, r[2]), h[2], dot(h[0], _sub(p, r[2])))
        t3, n3 = _spread(t3, n3, f3, spread)
        for j in range(n3):
            x = _add(r[2], rotate(h[2], t3[j], _sub(c, r[2])))
            t2, n2, f2 = sp3(_sub(x, r[1]), _sub(r[0], r[1]), h[1], _norm(_sub(p, r[0])))
            t2, n2 = _spread(t2, n2, f2, spread)
            for i in range(n2):
                y = _add(r[1], rotate(h[1], t2[i], _sub(x, r[1])))
                q1, f1 = sp1(_sub(y, r[0]), _sub(p, r[0]), h[0])
                out[n, 0], out[n, 1], out[n, 2] = q1, t2[i], t3[j]
                flags[n] = max(f1, f2, f3)
                n += 1
    return n


@nb.njit(**_JIT)
def spherical_wrist(G, h, r, prismatic3, c, position, spread, Q, count, flag):
    """Candidates of the spherical-wrist family for targets ``G`` (N, 4, 4) into ``Q``, ``count``, ``flag``."""
    pos = np.empty((4, 3))
    pflags = np.zeros(4, dtype=np.int64)
    u = _perpendicular(h[5])
    for t in range(G.shape[0]):
        g = G[t]
        p = _point(g, c)
        n_pos = _position_part(p, h, r, c, position, pos, pflags, spread)
        n = 0
        for a in range(n_pos):
            R = rot(h[0], pos[a, 0]) @ rot(h[1], pos[a, 1])
            if not prismatic3:
                R = R @ rot(h[2], pos[a, 2])
            Rw = R.T @ np.ascontiguousarray(g[:3, :3])
            t4, t5, n45, f45 = sp2(Rw @ h[5], h[5].copy(), h[3], h[4])
            for b in range(n45):
                q4, q5 = -t4[b], t5[b]
                v = rot(h[4], -q5) @ (rot(h[3], -q4) @ (Rw @ u))
                q6, f6 = sp1(u, v, h[5])
                Q[t, n, 0], Q[t, n, 1], Q[t, n, 2] = pos[a, 0], pos[a, 1], pos[a, 2]
                Q[t, n, 3], Q[t, n, 4], Q[t, n, 5] = q4, q5, q6
                flag[t, n] = max(pflags[a], f45, f6)
                n += 1
        count[t] = n


@nb.njit(**_JIT)
def three_parallel(G, h, r, c, spread, Q, count, flag):
    """Candidates of the three-parallel family (axes 2 ∥ 3 ∥ 4, axes 5, 6 meeting at ``c``)."""
    s3 = 1.0 if dot(h[1], h[2]) > 0 else -1.0
    s4 = 1.0 if dot(h[1], h[3]) > 0 else -1.0
    u = _perpendicular(h[1])
    for t in range(G.shape[0]):
        g = G[t]
        Rd = np.ascontiguousarray(g[:3, :3])
        p = _point(g, c)
        n = 0
        t1, n1, f1 = sp4(h[1], _sub(p, r[0]), h[0], dot(h[1], _sub(c, r[0])))
        t1, n1 = _spread(t1, n1, f1, spread)
        for i in range(n1):
            q1 = -t1[i]
            R1 = rot(h[0], q1)
            a = R1.T @ (Rd @ h[5])
            t5, n5, f5 = sp4(h[1], h[5].copy(), h[4], dot(h[1], a))
            t5, n5 = _spread(t5, n5, f5, spread)
            pp = _add(r[0], R1.T @ _sub(p, r[0]))
            for j in range(n5):
                q5 = t5[j]
                R5 = rot(h[4], q5)
                m6, f6 = sp1(R5.T @ h[1], Rd.T @ (R1 @ h[1]), h[5])
                q6 = -m6
                R234 = R1.T @ Rd @ rot(h[5], q6).T @ R5.T
                theta, f234 = sp1(u, R234 @ u, h[1])
                p4 = _sub(pp, R234 @ _sub(c, r[3]))
                t3, n3, f3 = sp3(_sub(r[3], r[2]), _sub(r[1], r[2]), h[2], _norm(_sub(p4, r[1])))
                t3, n3 = _spread(t3, n3, f3, spread)
                for k in range(n3):
                    x = _add(r[2], rotate(h[2], t3[k], _sub(r[3], r[2])))
                    q2, f2 = sp1(_sub(x, r[1]), _sub(p4, r[1]), h[1])
                    q3 = t3[k]
                    q4 = s4 * (theta - q2 - s3 * q3)
                    Q[t, n, 0], Q[t, n, 1], Q[t, n, 2] = q1, q2, q3
                    Q[t, n, 3], Q[t, n, 4], Q[t, n, 5] = q4, q5, q6
                    flag[t, n] = max(f1, f5, f6, f234, f3, f2)
                    n += 1
        count[t] = n


__all__ = ["MAX_CANDIDATES", "POS_PARALLEL_23", "POS_INTERSECT_12", "POS_INTERSECT_12_PRISMATIC", "POS_PARALLEL_12",
           "spherical_wrist", "three_parallel", "DEGENERATE"]


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
