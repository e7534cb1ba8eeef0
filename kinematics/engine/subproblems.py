"""The geometric subproblems (Paden-Kahan 1-3, Elias & Wen's 4 and 6), compiled with numba: the one
set that the closed forms of :mod:`kinematics.engine.ik_fast` run and the subproblem tests check.

They are written on 3-sequences (numpy arrays or 3-tuples) and answer tuples, so a compiled kernel
calls them without allocating an array per target. ``R(k, θ) = I + sin θ [k] + (1 - cos θ) [k]²``
is the rotation by θ about the unit axis k (right hand), so
``R(k, θ) p = cos θ p + sin θ k × p + (1 - cos θ)(k·p) k``.

| name | solves for θ (θ1, θ2) | answer |
|---|---|---|
| ``sp1(p1, p2, k)`` | ``R(k, θ) p1 = p2`` | ``(θ, flag)`` |
| ``sp2(p1, p2, k1, k2)`` | ``R(k1, θ1) p1 = R(k2, θ2) p2`` | ``((θ1a, θ1b), (θ2a, θ2b), count, flag)`` |
| ``sp3(p1, p2, k, d)`` | ``‖R(k, θ) p1 − p2‖ = d`` | ``((θa, θb), count, flag)`` |
| ``sp4(h, p, k, d)`` | ``hᵀ R(k, θ) p = d`` | ``((θa, θb), count, flag)`` |
| ``sp6(h, k, p, d1, d2)`` | two equations ``Σ hᵀ R(k, θ) p = d`` in (θ1, θ2) | ``(θ1 (4,), θ2 (4,), count, flag)`` |

Subproblem 5 (a point through three rotations) is not here: no family solved in closed form needs
it. ``sp1_cs`` and ``sp2_cs`` answer the cosine and sine of each angle as well (from the same two
numbers as the angle: a kernel that rotates by it needs no trigonometric call). Each returns the
solutions and a **flag**: ``EXACT`` (every returned θ satisfies the equation), ``LEAST_SQUARES``
(no exact solution: the returned θ minimises the equation's error -- a caller keeps it only when
the error is within its tolerance, e.g. a target just outside the reach by rounding) or
``DEGENERATE`` (infinitely many solutions -- the data leave θ free, e.g. ``p1`` on the axis; one
representative, θ = 0 where free, is returned).

Subproblems 3 and 4 reduce to ``A cos θ + B sin θ = C`` (:func:`trig_solve`): with
``r = hypot(A, B)`` and ``φ = atan2(B, A)``, ``θ = φ ± acos(C / r)``: two solutions when
``|C| < r``, one when ``|C| = r`` (within ``TANGENT``) and a least-squares ``θ = φ`` (``C > 0``)
or ``φ + π`` otherwise.

Rotating ``(1, 0, 0)`` onto ``(0, 1, 0)`` about z is a quarter turn:

>>> import numpy as np
>>> theta, flag = sp1(np.array([1.0, 0, 0]), np.array([0.0, 1, 0]), np.array([0.0, 0, 1]))
>>> round(theta, 12), flag == EXACT
(1.570796326795, True)
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

_JIT = dict(cache=True, nogil=True, boundscheck=False, error_model="numpy")
#: the small vector helpers and subproblems 1-4 are inlined into the kernels that call them
_INLINE = dict(inline="always", **_JIT)

#: flags of a subproblem's answer
EXACT, LEAST_SQUARES, DEGENERATE = 0, 1, 2
#: |C| within this of r counts as one (tangent) solution; below this, r counts as zero
TANGENT = 1e-12
ZERO = 1e-12


@nb.njit(**_INLINE)
def vec(a):
    """The 3-tuple of a 3-sequence (a row of an array)."""
    return (a[0], a[1], a[2])


@nb.njit(**_INLINE)
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@nb.njit(**_INLINE)
def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@nb.njit(**_INLINE)
def scale(s, a):
    return (s * a[0], s * a[1], s * a[2])


@nb.njit(**_INLINE)
def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@nb.njit(**_INLINE)
def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@nb.njit(**_INLINE)
def norm(a):
    return math.sqrt(dot(a, a))


@nb.njit(**_JIT)
def rot(k, theta):
    """The 3x3 rotation matrix ``R(k, θ)`` about the unit axis ``k``."""
    c, s = math.cos(theta), math.sin(theta)
    v = 1.0 - c
    R = np.empty((3, 3))
    R[0, 0] = c + k[0] * k[0] * v
    R[0, 1] = k[0] * k[1] * v - k[2] * s
    R[0, 2] = k[0] * k[2] * v + k[1] * s
    R[1, 0] = k[1] * k[0] * v + k[2] * s
    R[1, 1] = c + k[1] * k[1] * v
    R[1, 2] = k[1] * k[2] * v - k[0] * s
    R[2, 0] = k[2] * k[0] * v - k[1] * s
    R[2, 1] = k[2] * k[1] * v + k[0] * s
    R[2, 2] = c + k[2] * k[2] * v
    return R


@nb.njit(**_INLINE)
def rotate_cs(k, c, s, p):
    """``R(k, θ) p`` (3-tuple) from ``c = cos θ``, ``s = sin θ`` (a rotation used more than once:
    its sine and cosine once)."""
    kp = dot(k, p)
    kx = cross(k, p)
    w = (1.0 - c) * kp
    return (c * p[0] + s * kx[0] + w * k[0], c * p[1] + s * kx[1] + w * k[1], c * p[2] + s * kx[2] + w * k[2])


@nb.njit(**_INLINE)
def rotate(k, theta, p):
    """``R(k, θ) p`` (3-tuple)."""
    return rotate_cs(k, math.cos(theta), math.sin(theta), p)


@nb.njit(**_INLINE)
def trig_solve(A, B, C):
    """``((θa, θb), count, flag)`` of ``A cos θ + B sin θ = C``."""
    r = math.hypot(A, B)
    sc = max(r, abs(C), 1.0)
    if r <= ZERO * sc:
        return (0.0, 0.0), 1, (DEGENERATE if abs(C) <= ZERO * sc else LEAST_SQUARES)
    phi = math.atan2(B, A)
    x = C / r
    if x >= 1.0 + TANGENT:
        return (phi, 0.0), 1, LEAST_SQUARES
    if x <= -1.0 - TANGENT:
        return (phi + math.pi, 0.0), 1, LEAST_SQUARES
    if abs(abs(x) - 1.0) <= TANGENT:
        return ((phi if x > 0 else phi + math.pi), 0.0), 1, EXACT
    a = math.acos(x)
    return (phi + a, phi - a), 2, EXACT


@nb.njit(**_INLINE)
def sp1_cs(p1, p2, k):
    """``(θ, cos θ, sin θ, flag)`` of subproblem 1, ``R(k, θ) p1 = p2`` (least squares when the
    lengths or the heights along ``k`` of ``p1`` and ``p2`` differ; degenerate when either lies on
    the axis)."""
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


@nb.njit(**_INLINE)
def sp1(p1, p2, k):
    """``(θ, flag)`` of subproblem 1 (:func:`sp1_cs`)."""
    theta, _, _, flag = sp1_cs(p1, p2, k)
    return theta, flag


@nb.njit(**_INLINE)
def sp3(p1, p2, k, d):
    """``((θa, θb), count, flag)`` of ``‖R(k, θ) p1 − p2‖ = d``."""
    kp1, kp2 = dot(k, p1), dot(k, p2)
    a = sub(p1, scale(kp1, k))
    b = sub(p2, scale(kp2, k))
    # ‖R p1 − p2‖² = |a|² + |b|² − 2 (R a)·b + (kp1 − kp2)², (R a)·b = cos a·b + sin (k × a)·b
    return trig_solve(2.0 * dot(a, b), 2.0 * dot(cross(k, a), b), dot(a, a) + dot(b, b) + (kp1 - kp2) ** 2 - d * d)


@nb.njit(**_INLINE)
def sp4(h, p, k, d):
    """``((θa, θb), count, flag)`` of ``hᵀ R(k, θ) p = d``."""
    kp = dot(k, p)
    hk = dot(h, k)
    return trig_solve(dot(h, p) - hk * kp, dot(h, cross(k, p)), d - hk * kp)


@nb.njit(**_INLINE)
def sp2_image(p1, p2, k1, k2):
    """The common image of subproblem 2 (:func:`sp2`): ``(base, n, γ, count, flag)`` with the
    solutions ``x = base ± γ n`` (``base = α k1 + β k2``, ``n = k1 × k2``, as 3-tuples); count 1
    when γ = 0, flag least squares when the heights are out of reach, degenerate when ``k1 ∥ k2``."""
    c12 = dot(k1, k2)
    s2 = 1.0 - c12 * c12
    if s2 <= 1e-14:
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, 1, DEGENERATE
    h1, h2 = dot(k1, p1), dot(k2, p2)
    alpha = (h1 - c12 * h2) / s2
    beta = (h2 - c12 * h1) / s2
    n = cross(k1, k2)
    base = add(scale(alpha, k1), scale(beta, k2))
    # the common length: the mean of |p1| and |p2| (they are equal for an exact instance)
    length2 = 0.5 * (dot(p1, p1) + dot(p2, p2))
    g2 = (length2 - dot(base, base)) / s2
    flag = EXACT
    count = 2
    sc = max(length2, 1.0)
    if g2 < -1e-12 * sc:
        flag = LEAST_SQUARES
        g2 = 0.0
        count = 1
    elif g2 <= 1e-12 * sc:
        g2 = 0.0
        count = 1
    return base, n, math.sqrt(g2), count, flag


@nb.njit(**_INLINE)
def sp2_cs(p1, p2, k1, k2):
    """:func:`sp2` with the cosine and sine of the four angles:
    ``((θ1a, θ1b), (θ2a, θ2b), count, flag, (cos θ1a, sin θ1a, cos θ1b, sin θ1b, cos θ2a, ...))``."""
    base, n, g, count, flag = sp2_image(p1, p2, k1, k2)
    if flag == DEGENERATE:
        return (0.0, 0.0), (0.0, 0.0), 1, DEGENERATE, (1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0)
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
    return (a0, a1), (b0, b1), count, flag, (ca0, sa0, ca1, sa1, cb0, sb0, cb1, sb1)


@nb.njit(**_INLINE)
def sp2(p1, p2, k1, k2):
    """``((θ1a, θ1b), (θ2a, θ2b), count, flag)`` of ``R(k1, θ1) p1 = R(k2, θ2) p2`` (k1 not parallel
    to k2).

    The common image ``x = α k1 + β k2 + γ k1 × k2`` keeps the heights ``k1·x = k1·p1``,
    ``k2·x = k2·p2`` and the length ``|x| = |p1|``; γ = ±√(...) gives the two solutions, then
    :func:`sp1` rotates each of ``p1``, ``p2`` onto x. Least squares (γ = 0) when the heights are
    out of reach; degenerate when ``k1 ∥ k2`` or a vector lies on its axis.
    """
    t1, t2, count, flag, _ = sp2_cs(p1, p2, k1, k2)
    return t1, t2, count, flag



#: a subproblem 6 answer is exact when both equations hold within this, relative to the data's size
SP6_RESIDUAL = 1e-12
#: roots of the quartic with an imaginary part below this (relative) are real; up to ``SP6_NEAR_REAL``
#: a root may be half of a near-double pair that rounding pushed off the real line: it is polished
#: and kept only if it then solves the equations
SP6_REAL, SP6_NEAR_REAL = 1e-7, 1e-3
#: Newton steps that polish each root on the two equations themselves
SP6_NEWTON = 30
#: two answers closer than this in both angles are one
SP6_SAME = 1e-9


@nb.njit(**_JIT)
def _terms(h, k, p):
    """``hᵀ R(k, θ) p = a cos θ + b sin θ + c``: (a, b, c)."""
    kp = dot(k, p)
    hk = dot(h, k)
    return dot(h, p) - hk * kp, dot(h, cross(k, p)), hk * kp


@nb.njit(**_JIT)
def _sp6_residual(L, e1, e2, t1, t2):
    """The two equations' errors at (θ1, θ2), ``L = (a1, b1, a2, b2, a3, b3, a4, b4)`` the cosine and
    sine coefficients of the four terms (θ1, θ2, θ1, θ2)."""
    c1, s1, c2, s2 = math.cos(t1), math.sin(t1), math.cos(t2), math.sin(t2)
    return (L[0] * c1 + L[1] * s1 + L[2] * c2 + L[3] * s2 - e1,
            L[4] * c1 + L[5] * s1 + L[6] * c2 + L[7] * s2 - e2)


@nb.njit(**_JIT)
def _sp6_polish(L, e1, e2, t1, t2):
    """Newton on the two equations from (θ1, θ2) (Levenberg-damped where the Jacobian is singular, as
    at a double root); a step that does not lower the error is refused. ``(θ1, θ2, max |error|)``."""
    f1, f2 = _sp6_residual(L, e1, e2, t1, t2)
    err = max(abs(f1), abs(f2))
    for _ in range(SP6_NEWTON):
        if err == 0.0:
            break
        c1, s1, c2, s2 = math.cos(t1), math.sin(t1), math.cos(t2), math.sin(t2)
        j11, j12 = L[1] * c1 - L[0] * s1, L[3] * c2 - L[2] * s2
        j21, j22 = L[5] * c1 - L[4] * s1, L[7] * c2 - L[6] * s2
        # (JᵀJ + λI) δ = −Jᵀ f, λ tiny: Newton's step where J is regular
        g11 = j11 * j11 + j21 * j21
        g12 = j11 * j12 + j21 * j22
        g22 = j12 * j12 + j22 * j22
        lam = 1e-13 * (g11 + g22) + 1e-300
        r1, r2 = -(j11 * f1 + j21 * f2), -(j12 * f1 + j22 * f2)
        det = (g11 + lam) * (g22 + lam) - g12 * g12
        d1 = ((g22 + lam) * r1 - g12 * r2) / det
        d2 = ((g11 + lam) * r2 - g12 * r1) / det
        n1, n2 = t1 + d1, t2 + d2
        h1, h2 = _sp6_residual(L, e1, e2, n1, n2)
        new = max(abs(h1), abs(h2))
        if not new < err:
            break
        t1, t2, f1, f2, err = n1, n2, h1, h2, new
    return t1, t2, err


@nb.njit(**_JIT)
def _sp6_quartic(a1, b1, a3, b3, a2, b2, a4, b4, e1, e2, cands, real):
    """Candidates of the angle θ of ``(a1, b1; a3, b3)`` after eliminating the other angle φ (its
    block ``B = (a2, b2; a4, b4)``, invertible): ``(cos φ, sin φ) = B⁻¹ (e − A (cos θ, sin θ))``
    has unit length, a quadratic form in (cos θ, sin θ), and ``t = tan(θ / 2)`` makes it a quartic.
    Writes ``(θ, cos φ, sin φ)`` rows into ``cands`` and whether the root was real into ``real``;
    returns their number."""
    det = a2 * b4 - b2 * a4
    i11, i12, i21, i22 = b4 / det, -b2 / det, -a4 / det, a2 / det
    # (cos φ, sin φ) = u + U (cos θ, sin θ)
    u1 = i11 * e1 + i12 * e2
    u2 = i21 * e1 + i22 * e2
    U11 = -(i11 * a1 + i12 * a3)
    U12 = -(i11 * b1 + i12 * b3)
    U21 = -(i21 * a1 + i22 * a3)
    U22 = -(i21 * b1 + i22 * b3)
    # |u + U x|² − 1 = m11 c² + 2 m12 c s + m22 s² + 2 n1 c + 2 n2 s + w
    m11 = U11 * U11 + U21 * U21
    m12 = U11 * U12 + U21 * U22
    m22 = U12 * U12 + U22 * U22
    n1 = u1 * U11 + u2 * U21
    n2 = u1 * U12 + u2 * U22
    w = u1 * u1 + u2 * u2 - 1.0
    # c = (1 − t²)/(1 + t²), s = 2t/(1 + t²), times (1 + t²)²
    coeffs = np.zeros(5)
    coeffs[0] = m11 - 2.0 * n1 + w                      # t⁴
    coeffs[1] = -4.0 * m12 + 4.0 * n2                   # t³
    coeffs[2] = -2.0 * m11 + 4.0 * m22 + 2.0 * w        # t²
    coeffs[3] = 4.0 * m12 + 4.0 * n2                    # t
    coeffs[4] = m11 + 2.0 * n1 + w                      # 1
    nc = 0
    big = max(abs(coeffs[0]), abs(coeffs[1]), abs(coeffs[2]), abs(coeffs[3]), abs(coeffs[4]), 1e-300)
    thetas = np.zeros(5)
    if abs(coeffs[0]) <= 1e-10 * big:  # a root at (or near) t = ∞: θ = π
        thetas[nc] = math.pi
        real[nc] = True
        nc += 1
    first = 0
    while first < 4 and abs(coeffs[first]) <= 1e-14 * big:
        first += 1
    if first < 4:
        roots = np.roots(coeffs[first:].astype(np.complex128))
        for r in roots:
            scale_r = max(1.0, abs(r.real))
            if abs(r.imag) <= SP6_NEAR_REAL * scale_r:
                thetas[nc] = 2.0 * math.atan(r.real)
                real[nc] = abs(r.imag) <= SP6_REAL * scale_r
                nc += 1
    for i in range(nc):
        c, s = math.cos(thetas[i]), math.sin(thetas[i])
        cands[i, 0] = thetas[i]
        cands[i, 1] = u1 + U11 * c + U12 * s
        cands[i, 2] = u2 + U21 * c + U22 * s
    return nc


@nb.njit(**_JIT)
def sp6(h, k, p, d1, d2):
    """θ1 (4,), θ2 (4,), count and flag of Elias & Wen's subproblem 6:

        h[0]ᵀ R(k[0], θ1) p[0] + h[1]ᵀ R(k[1], θ2) p[1] = d1
        h[2]ᵀ R(k[2], θ1) p[2] + h[3]ᵀ R(k[3], θ2) p[3] = d2

    (``h``, ``k``, ``p``: (4, 3)). Each term is linear in ``x1 = (cos θ1, sin θ1)`` or
    ``x2 = (cos θ2, sin θ2)``: ``A x1 + B x2 = e``. The better-conditioned of A, B is inverted
    and the other angle's unit circle gives a quartic in ``t = tan(θ / 2)`` (θ = π checked apart).
    Its roots are seeds only: near a double root (two solutions with almost the same angle) the
    quartic's roots lose half their digits, and a near-double pair may even come out complex. So
    every real or nearly real root is polished by Newton on the two equations themselves, the
    answers closer than ``SP6_SAME`` merged, and a nearly real root kept only if it then solves
    them. ``EXACT``: every answer satisfies both equations within ``SP6_RESIDUAL`` times the
    data's size; ``LEAST_SQUARES``: some answer (a real root of the quartic that Newton could not
    bring onto the equations: a tangency just missed) does not, and is the best point found near
    it; ``DEGENERATE``: A and B are both singular (count 0). Count 0 with ``EXACT``: no solution."""
    t1 = np.zeros(4)
    t2 = np.zeros(4)
    a1, b1, c1 = _terms(h[0], k[0], p[0])
    a2, b2, c2 = _terms(h[1], k[1], p[1])
    a3, b3, c3 = _terms(h[2], k[2], p[2])
    a4, b4, c4 = _terms(h[3], k[3], p[3])
    e1, e2 = d1 - c1 - c2, d2 - c3 - c4
    L = (a1, b1, a2, b2, a3, b3, a4, b4)
    # conditioning of each 2x2 block: |det| / (squared size)
    nA = max(a1 * a1 + b1 * b1 + a3 * a3 + b3 * b3, 1e-300)
    nB = max(a2 * a2 + b2 * b2 + a4 * a4 + b4 * b4, 1e-300)
    kA = abs(a1 * b3 - b1 * a3) / nA
    kB = abs(a2 * b4 - b2 * a4) / nB
    if max(kA, kB) <= 1e-12:
        return t1, t2, 0, DEGENERATE
    cands = np.zeros((5, 3))
    real = np.zeros(5, dtype=np.bool_)
    swap = kA > kB
    if swap:  # eliminate θ1: the quartic is in θ2
        nc = _sp6_quartic(a2, b2, a4, b4, a1, b1, a3, b3, e1, e2, cands, real)
    else:
        nc = _sp6_quartic(a1, b1, a3, b3, a2, b2, a4, b4, e1, e2, cands, real)
    size = max(1.0, abs(d1), abs(d2), abs(e1), abs(e2), math.sqrt(nA + nB))
    tol = SP6_RESIDUAL * size
    flag = EXACT
    count = 0
    for i in range(nc):
        th, ph = cands[i, 0], math.atan2(cands[i, 2], cands[i, 1])
        x, y = (ph, th) if swap else (th, ph)
        x, y, err = _sp6_polish(L, e1, e2, x, y)
        if err > tol and not real[i]:
            continue  # a complex root: no solution near it
        x = math.atan2(math.sin(x), math.cos(x))
        y = math.atan2(math.sin(y), math.cos(y))
        dup = False
        for j in range(count):
            if (abs(math.atan2(math.sin(x - t1[j]), math.cos(x - t1[j]))) < SP6_SAME
                    and abs(math.atan2(math.sin(y - t2[j]), math.cos(y - t2[j]))) < SP6_SAME):
                dup = True
        if dup or count >= 4:
            continue
        if err > tol:
            flag = LEAST_SQUARES
        t1[count] = x
        t2[count] = y
        count += 1
    return t1, t2, count, flag
