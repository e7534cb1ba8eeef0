"""Every solution of a batch of targets from closed-form candidates, in one compiled pass per target.

:func:`polish` takes, for targets ``a..b`` of a batch, the candidates of a chain's closed form
(``cand`` (N, C, 6), ``ccount`` (N,); on the reversed chain when ``reversed``) and, per target and
candidate, without leaving compiled code:

1. maps the candidate to the chain's joint values (``x_k = −c_{n−1−k}`` for a reversed chain) and
   wraps revolute joints into (−π, π];
2. measures the pose error on the **real** chain (the model's screws ``h``, ``r``, home ``M``,
   locked joints folded in: ``F = E_1(x_1) ... E_n(x_n) M``); a row not on its solution to
   ``tight`` gets up to ``steps`` Levenberg-Marquardt steps (the rule of
   :func:`kinematics.algorithms.ik_all.newton`: λ /4 on a step that lowers the squared error, x8 on
   one that does not, a row stops once converged or stuck), and a row near a solution but not on it
   ``final`` more;
3. keeps it when the position error is within ``ptol`` and the rotation error within ``rtol``,
   and no earlier kept solution of the target is within ``dup`` in every joint (revolute modulo 2π);
4. writes the full configuration (``base`` with the chain's ``columns`` set) to ``Q[t, k]``, its
   errors, ``within`` (inside ``lower``/``upper`` to ``limit_tol``) and ``sing``: 1 where σ_min /
   σ_max of the chain's 6 x n Jacobian is at most ``singular`` (decided by the lower bound
   ``|det J| / ‖J‖_F^6`` where it is above, else by the eigenvalues of ``JᵀJ``); slots past
   ``count[t]`` are NaN / False.

:func:`nominal` counts, per target, the ideal chain's distinct candidates that meet the tolerances
on the ideal chain's own FK (a near family's reference count).

Each target's arithmetic depends only on its own inputs: a target alone gets its batch answer, and
the caller runs row ranges on the engine's threads (the kernels release the GIL).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

# the FK kernel's joint frames and sine/cosine row, private to the engine: the polish evaluates the same frames
from .compiled import J_CZ, _joint_frames, _sincos_row
from .ik import rotation_log
from .plans import axis_frame
from ..spatial.transforms import inverse_transform

_JIT = dict(cache=True, nogil=True, boundscheck=False, error_model="numpy", fastmath={"contract"})

#: a squared pose error below this is converged
CONVERGED = 1e-28
#: a squared pose error below this whose next step is refused is at the rounding floor (Newton stops)
FLOOR = 1e-26
#: targets whose candidates share one pass of the lane stage, at most, and candidates (lanes) in one pass
#: at most (a search's hundreds of seeds: one target a pass)
LANE_TARGETS, LANE_CANDIDATES = 32, 256
#: the lane stage's rotation error (atan of sin/cos by its series) where sin θ is below this and cos θ > 0
LANE_SMALL_ANGLE = 1e-4


def lane_table(h: np.ndarray, r: np.ndarray, M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The chain ``h``, ``r`` (n, 3), ``M`` (4, 4) in the FK kernel's axis-frame form
    (:mod:`kinematics.engine.compiled`): ``table`` (n, 14) with ``CZ_j = G_{j-1}⁻¹ G_j`` in the
    columns from ``J_CZ`` (``G_j``: z along ``h_j``, origin ``r_j``) and ``D = G_n⁻¹ M`` (4, 4), so that
    ``F_j = F_{j-1} CZ_j Z(x_j)`` and the end pose is ``F_n D``."""
    n = h.shape[0]
    G = [axis_frame(np.asarray(h[j], dtype=float), np.asarray(r[j], dtype=float)) for j in range(n)]
    table = np.zeros((n, 14))
    for j in range(n):
        CZ = G[j] if j == 0 else inverse_transform(G[j - 1]) @ G[j]
        table[j, J_CZ:] = CZ[:3, :].reshape(12)
    return table, np.ascontiguousarray(inverse_transform(G[-1]) @ M)


def chain_arguments(columns: np.ndarray, h: np.ndarray, r: np.ndarray, rev: np.ndarray, M: np.ndarray) -> tuple:
    """The real chain as :func:`polish` takes it: ``(columns, h, r, rev, M, table, D)``, contiguous,
    with :func:`lane_table`'s form."""
    arrays = tuple(np.ascontiguousarray(x) for x in (h, r, rev, M))
    return (np.ascontiguousarray(columns, dtype=np.intp),) + arrays + lane_table(arrays[0], arrays[1], arrays[3])


def polish_settings(steps: int, lam0: float, damped: bool, middle: int, tight: float, final: int, reach: float,
                    ptol: float, rtol: float, dup: float, singular: float) -> tuple:
    """The settings of :func:`polish` as one tuple of fixed types (one compiled signature)."""
    return (int(steps), float(lam0), bool(damped), int(middle), float(tight), int(final), float(reach), float(ptol),
            float(rtol), float(dup), float(singular))


@nb.njit(inline="always", **_JIT)
def chain_fk(h, r, rev, M, x, F, W, O, sn, cs):
    """``F = E_1(x_1) ... E_n(x_n) M`` (4, 4); ``W[j]``, ``O[j]``: joint j's axis and axis point in
    the world frame at ``x`` (what the Jacobian needs); ``sn``, ``cs`` (n,): scratch (the sines and
    cosines, by the FK kernel's polynomial)."""
    _sincos_row(x, sn, cs, x.shape[0])
    R00, R01, R02, R10, R11, R12, R20, R21, R22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
    p0, p1, p2 = 0.0, 0.0, 0.0
    for j in range(h.shape[0]):
        k0, k1, k2 = h[j, 0], h[j, 1], h[j, 2]
        W[j, 0] = R00 * k0 + R01 * k1 + R02 * k2
        W[j, 1] = R10 * k0 + R11 * k1 + R12 * k2
        W[j, 2] = R20 * k0 + R21 * k1 + R22 * k2
        a0, a1, a2 = r[j, 0], r[j, 1], r[j, 2]
        O[j, 0] = R00 * a0 + R01 * a1 + R02 * a2 + p0
        O[j, 1] = R10 * a0 + R11 * a1 + R12 * a2 + p1
        O[j, 2] = R20 * a0 + R21 * a1 + R22 * a2 + p2
        if rev[j]:
            c, s = cs[j], sn[j]
            v = 1.0 - c
            E00, E01, E02 = c + v * k0 * k0, v * k0 * k1 - s * k2, v * k0 * k2 + s * k1
            E10, E11, E12 = v * k0 * k1 + s * k2, c + v * k1 * k1, v * k1 * k2 - s * k0
            E20, E21, E22 = v * k0 * k2 - s * k1, v * k1 * k2 + s * k0, c + v * k2 * k2
            t0 = a0 - (E00 * a0 + E01 * a1 + E02 * a2)
            t1 = a1 - (E10 * a0 + E11 * a1 + E12 * a2)
            t2 = a2 - (E20 * a0 + E21 * a1 + E22 * a2)
            p0, p1, p2 = (p0 + R00 * t0 + R01 * t1 + R02 * t2, p1 + R10 * t0 + R11 * t1 + R12 * t2,
                          p2 + R20 * t0 + R21 * t1 + R22 * t2)
            R00, R01, R02 = (R00 * E00 + R01 * E10 + R02 * E20, R00 * E01 + R01 * E11 + R02 * E21,
                             R00 * E02 + R01 * E12 + R02 * E22)
            R10, R11, R12 = (R10 * E00 + R11 * E10 + R12 * E20, R10 * E01 + R11 * E11 + R12 * E21,
                             R10 * E02 + R11 * E12 + R12 * E22)
            R20, R21, R22 = (R20 * E00 + R21 * E10 + R22 * E20, R20 * E01 + R21 * E11 + R22 * E21,
                             R20 * E02 + R21 * E12 + R22 * E22)
        else:
            d = x[j]
            p0 += d * W[j, 0]
            p1 += d * W[j, 1]
            p2 += d * W[j, 2]
    for i in range(3):
        m0, m1, m2 = M[0, i], M[1, i], M[2, i]
        F[0, i] = R00 * m0 + R01 * m1 + R02 * m2
        F[1, i] = R10 * m0 + R11 * m1 + R12 * m2
        F[2, i] = R20 * m0 + R21 * m1 + R22 * m2
    m0, m1, m2 = M[0, 3], M[1, 3], M[2, 3]
    F[0, 3] = R00 * m0 + R01 * m1 + R02 * m2 + p0
    F[1, 3] = R10 * m0 + R11 * m1 + R12 * m2 + p1
    F[2, 3] = R20 * m0 + R21 * m1 + R22 * m2 + p2


@nb.njit(inline="always", **_JIT)
def pose_error(F, T, e, R, out):
    """``e = (p_T − p_F, log(R_T R_Fᵀ))`` (6,); returns the squared norm."""
    for a in range(3):
        e[a] = T[a, 3] - F[a, 3]
        for b in range(3):
            R[a, b] = T[a, 0] * F[b, 0] + T[a, 1] * F[b, 1] + T[a, 2] * F[b, 2]
    rotation_log(R, out)
    e[3], e[4], e[5] = out[0], out[1], out[2]
    s = 0.0
    for a in range(6):
        s += e[a] * e[a]
    return s


@nb.njit(inline="always", **_JIT)
def chain_jacobian(rev, F, W, O, J):
    """The 6 x n Jacobian of the chain's end point (linear rows first, world axes) from ``chain_fk``'s W, O."""
    px, py, pz = F[0, 3], F[1, 3], F[2, 3]
    for j in range(W.shape[0]):
        wx, wy, wz = W[j, 0], W[j, 1], W[j, 2]
        if rev[j]:
            dx, dy, dz = px - O[j, 0], py - O[j, 1], pz - O[j, 2]
            J[0, j] = wy * dz - wz * dy
            J[1, j] = wz * dx - wx * dz
            J[2, j] = wx * dy - wy * dx
            J[3, j], J[4, j], J[5, j] = wx, wy, wz
        else:
            J[0, j], J[1, j], J[2, j] = wx, wy, wz
            J[3, j], J[4, j], J[5, j] = 0.0, 0.0, 0.0


@nb.njit(**_JIT)
def damped_step(J, e, lam, A, b, dq):
    """``dq = (JᵀJ + λI)⁻¹ Jᵀ e`` by Cholesky (plain loops); False (and dq = 0) when the factor is
    not positive."""
    m, n = J.shape
    for r in range(n):
        s = 0.0
        for k in range(m):
            s += J[k, r] * e[k]
        b[r] = s
        for c in range(r + 1):
            s = 0.0
            for k in range(m):
                s += J[k, r] * J[k, c]
            A[r, c] = s
        A[r, r] += lam
    for r in range(n):
        for c in range(r + 1):
            s = A[r, c]
            for k in range(c):
                s -= A[r, k] * A[c, k]
            if r == c:
                if s <= 0.0:
                    for i in range(n):
                        dq[i] = 0.0
                    return False
                A[r, r] = math.sqrt(s)
            else:
                A[r, c] = s / A[c, c]
    for r in range(n):
        s = b[r]
        for k in range(r):
            s -= A[r, k] * b[k]
        b[r] = s / A[r, r]
    for r in range(n - 1, -1, -1):
        s = b[r]
        for k in range(r + 1, n):
            s -= A[k, r] * b[k]
        b[r] = s / A[r, r]
    for r in range(n):
        dq[r] = b[r]
    return True


@nb.njit(inline="always", **_JIT)
def wrapped(v):
    """A revolute value into (−π, π] (a value already inside is left as it is)."""
    if v > math.pi or v <= -math.pi + 1e-15:
        w = v - 2.0 * math.pi * math.floor((v + math.pi) / (2.0 * math.pi))
        if w > math.pi:
            w -= 2.0 * math.pi
        return math.pi if w <= -math.pi + 1e-15 else w
    return v


@nb.njit(inline="always", **_JIT)
def wrap(x, rev):
    """Revolute values into (−π, π] (:func:`wrapped`, in place)."""
    for j in range(x.shape[0]):
        if rev[j]:
            x[j] = wrapped(x[j])


@nb.njit(inline="always", **_JIT)
def same_solution(x, y, rev, dup):
    """Every joint of x and y within ``dup`` (revolute: both in (−π, π], compared modulo 2π)."""
    for j in range(x.shape[0]):
        d = abs(x[j] - y[j])
        if d > dup and not (rev[j] and d >= 2.0 * math.pi - dup):
            return False
    return True


@nb.njit(inline="always", **_JIT)
def close_rows(x, y, columns, rev, tol):
    """Every entry ``columns[c]`` of x and y within ``tol`` (``rev[c]``: compared modulo 2π, the
    values in any range)."""
    for c in range(columns.shape[0]):
        d = x[columns[c]] - y[columns[c]]
        if rev[c]:
            d = (d + math.pi) % (2.0 * math.pi) - math.pi
        if abs(d) > tol:
            return False
    return True


@nb.njit(**_JIT)
def scratch(n):
    """The work arrays of :func:`chain_error` and :func:`levenberg_marquardt` for a chain of ``n``
    joints, as one tuple: ``(F, W, O, J, e, R, out, A, b, dq, trial, sn, cs)``."""
    return (np.empty((4, 4)), np.empty((n, 3)), np.empty((n, 3)), np.empty((6, n)), np.empty(6), np.empty((3, 3)),
            np.empty(3), np.empty((n, n)), np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n))


@nb.njit(inline="always", **_JIT)
def chain_error(chain, x, T, work):
    """The end pose of ``chain = (h, r, rev, M)`` at ``x`` (:func:`chain_fk`, into ``work``'s ``F``) and
    its error ``e`` to ``T`` (:func:`pose_error`); returns the position error (metres) and the rotation
    error (radians). ``work``: :func:`scratch`."""
    h, r, rev, M = chain
    F, W, O, J, e, R, out, A, b, dq, trial, sn, cs = work
    chain_fk(h, r, rev, M, x, F, W, O, sn, cs)
    pose_error(F, T, e, R, out)
    return (math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]),
            math.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5]))


@nb.njit(**_JIT)
def levenberg_marquardt(chain, T, x, steps, lam, damped, work):
    """Up to ``steps`` LM steps of ``x`` (n,) of ``chain = (h, r, rev, M)`` towards ``T`` from the
    damping ``lam`` (``damped``: steps of at most 0.5 per joint); returns the final squared error
    (``work``, :func:`scratch`: ``F``, ``e`` at x)."""
    h, r, rev, M = chain
    F, W, O, J, e, R, out, A, b, dq, trial, sn, cs = work
    n = x.shape[0]
    chain_fk(h, r, rev, M, x, F, W, O, sn, cs)
    cost = pose_error(F, T, e, R, out)
    for _ in range(steps):
        if cost <= CONVERGED or lam >= 1e6:
            break
        chain_jacobian(rev, F, W, O, J)
        damped_step(J, e, lam, A, b, dq)
        if damped:
            big = 0.0
            for j in range(n):
                big = max(big, abs(dq[j]))
            if big > 0.5:
                for j in range(n):
                    dq[j] *= 0.5 / big
        for j in range(n):
            trial[j] = x[j] + dq[j]
        chain_fk(h, r, rev, M, trial, F, W, O, sn, cs)
        cost2 = pose_error(F, T, e, R, out)
        if cost2 < cost:
            for j in range(n):
                x[j] = trial[j]
            cost = cost2
            lam = max(lam / 4.0, 1e-15)
        else:  # refused: back to the frames and error at x
            if cost <= FLOOR:  # on the solution to rounding: no step lowers the error any more
                break
            lam = min(lam * 8.0, 1e6)
            chain_fk(h, r, rev, M, x, F, W, O, sn, cs)
            cost = pose_error(F, T, e, R, out)
    return cost


@nb.njit(inline="always", **_JIT)
def det_bound(J, A):
    """``|det J| / ‖J‖_F^n`` of a square J (n, n) by LU with partial pivoting (A: scratch (n, n))."""
    n = J.shape[1]
    fro = 0.0
    for i in range(n):
        for j in range(n):
            A[i, j] = J[i, j]
            fro += J[i, j] * J[i, j]
    fro = math.sqrt(fro)
    det = 1.0
    for k in range(n):
        piv = k
        for i in range(k + 1, n):
            if abs(A[i, k]) > abs(A[piv, k]):
                piv = i
        if A[piv, k] == 0.0:
            return 0.0
        if piv != k:
            for j in range(n):
                A[k, j], A[piv, j] = A[piv, j], A[k, j]
        det *= A[k, k]
        for i in range(k + 1, n):
            f = A[i, k] / A[k, k]
            for j in range(k, n):
                A[i, j] -= f * A[k, j]
    return abs(det) / max(fro, 1e-300) ** n


@nb.njit(**_JIT)
def singular_ratio2(J, A):
    """(σ_min / σ_max)² of J (m, n): the extreme eigenvalues of ``JᵀJ`` by cyclic Jacobi rotations
    (A: scratch (n, n))."""
    m, n = J.shape
    for i in range(n):
        for j in range(n):
            s = 0.0
            for k in range(m):
                s += J[k, i] * J[k, j]
            A[i, j] = s
    for _ in range(30):
        off = 0.0
        diag = 0.0
        for i in range(n):
            diag += A[i, i] * A[i, i]
            for j in range(i + 1, n):
                off += A[i, j] * A[i, j]
        if off <= 1e-32 * diag:
            break
        for p in range(n - 1):
            for q in range(p + 1, n):
                apq = A[p, q]
                if apq == 0.0:
                    continue
                theta = 0.5 * (A[q, q] - A[p, p]) / apq
                t = (1.0 if theta >= 0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                c = 1.0 / math.sqrt(t * t + 1.0)
                sn = t * c
                for k in range(n):
                    akp, akq = A[k, p], A[k, q]
                    A[k, p], A[k, q] = c * akp - sn * akq, sn * akp + c * akq
                for k in range(n):
                    apk, aqk = A[p, k], A[q, k]
                    A[p, k], A[q, k] = c * apk - sn * aqk, sn * apk + c * aqk
    lo, hi = A[0, 0], A[0, 0]
    for i in range(1, n):
        lo = min(lo, A[i, i])
        hi = max(hi, A[i, i])
    return max(lo, 0.0) / max(hi, 1e-300)


@nb.njit(**_JIT)
def _gram_index(a, b):
    """The slot of entry (a, b), b <= a, of a packed lower triangle."""
    return a * (a + 1) // 2 + b


@nb.njit(**_JIT)
def lane_stage(cand, ccount, reversed_, targets, rev, table, D, t0, t1, lanes):
    """The cheap first look at every candidate of targets ``t0..t1``, one candidate per lane, in loops
    LLVM vectorises over the lanes (the FK kernel's axis-frame products, :func:`lane_table`'s form).
    ``lanes = (X, F, S, TT, E, JL, Gm, lp, lq, lb)``, the lane arrays, of which it writes

    - ``X`` (n, L): the candidates' joint values (mapped for a ``reversed_`` chain, revolute wrapped
      into (−π, π]), target by target, candidate by candidate;
    - ``lp``, ``lq`` (L,): position and rotation errors on the real chain; ``lq`` is NaN where the
      rotation error is not small (``sin θ`` at least :data:`LANE_SMALL_ANGLE` or ``cos θ <= 0``:
      the scalar :func:`chain_error` decides there);
    - ``lb`` (L,): ``|det J| / ‖J‖_F^6`` of the 6 x 6 Jacobian at the end point, from the Cholesky
      factor of ``JᵀJ`` (NaN where that factor breaks down, or n != 6: the scalar test decides).

    Returns the number of lanes used."""
    X, F, S, TT, E, JL, Gm, lp, lq, lb = lanes
    n = rev.shape[0]
    m = 0
    for t in range(t0, t1):
        T = targets[t]
        for c in range(ccount[t]):
            for j in range(n):
                v = -cand[t, c, n - 1 - j] if reversed_ else cand[t, c, j]
                X[j, m] = wrapped(v) if rev[j] else v
            for a in range(3):
                for b in range(4):
                    TT[4 * a + b, m] = T[a, b]
            m += 1
    for j in range(n):
        _sincos_row(X[j], S[0, j], S[1, j], m)
        _joint_frames(F, j, j - 1, rev[j], table[j], S[0, j], S[1, j], X[j], m)
    Fn = F[n - 1]
    for a in range(3):
        f0, f1, f2, f3 = Fn[4 * a], Fn[4 * a + 1], Fn[4 * a + 2], Fn[4 * a + 3]
        for b in range(4):
            e = E[4 * a + b]
            d0, d1, d2, d3 = D[0, b], D[1, b], D[2, b], D[3, b]
            for i in range(m):
                e[i] = f0[i] * d0 + f1[i] * d1 + f2[i] * d2 + f3[i] * d3
    for i in range(m):
        dx, dy, dz = TT[3, i] - E[3, i], TT[7, i] - E[7, i], TT[11, i] - E[11, i]
        lp[i] = math.sqrt(dx * dx + dy * dy + dz * dz)
        # R = R_T R_Fᵀ: its skew part and trace
        r01 = TT[0, i] * E[4, i] + TT[1, i] * E[5, i] + TT[2, i] * E[6, i]
        r02 = TT[0, i] * E[8, i] + TT[1, i] * E[9, i] + TT[2, i] * E[10, i]
        r10 = TT[4, i] * E[0, i] + TT[5, i] * E[1, i] + TT[6, i] * E[2, i]
        r12 = TT[4, i] * E[8, i] + TT[5, i] * E[9, i] + TT[6, i] * E[10, i]
        r20 = TT[8, i] * E[0, i] + TT[9, i] * E[1, i] + TT[10, i] * E[2, i]
        r21 = TT[8, i] * E[4, i] + TT[9, i] * E[5, i] + TT[10, i] * E[6, i]
        tr = (TT[0, i] * E[0, i] + TT[1, i] * E[1, i] + TT[2, i] * E[2, i]
              + TT[4, i] * E[4, i] + TT[5, i] * E[5, i] + TT[6, i] * E[6, i]
              + TT[8, i] * E[8, i] + TT[9, i] * E[9, i] + TT[10, i] * E[10, i])
        vx, vy, vz = 0.5 * (r21 - r12), 0.5 * (r02 - r20), 0.5 * (r10 - r01)
        sn = math.sqrt(vx * vx + vy * vy + vz * vz)
        cs = 0.5 * (tr - 1.0)
        x = sn / cs
        x2 = x * x
        theta = x * (1.0 - x2 * (1.0 / 3.0 - x2 * 0.2))  # atan(x), to rounding for x < 1e-4
        lq[i] = theta if (cs > 0.0 and sn < LANE_SMALL_ANGLE) else np.nan
    if n != 6:
        for i in range(m):
            lb[i] = np.nan
        return m
    for j in range(6):
        Fj = F[j]
        if rev[j]:
            for i in range(m):
                wx, wy, wz = Fj[2, i], Fj[6, i], Fj[10, i]
                dx, dy, dz = E[3, i] - Fj[3, i], E[7, i] - Fj[7, i], E[11, i] - Fj[11, i]
                JL[6 * j, i] = wy * dz - wz * dy
                JL[6 * j + 1, i] = wz * dx - wx * dz
                JL[6 * j + 2, i] = wx * dy - wy * dx
                JL[6 * j + 3, i], JL[6 * j + 4, i], JL[6 * j + 5, i] = wx, wy, wz
        else:
            for i in range(m):
                JL[6 * j, i], JL[6 * j + 1, i], JL[6 * j + 2, i] = Fj[2, i], Fj[6, i], Fj[10, i]
                JL[6 * j + 3, i], JL[6 * j + 4, i], JL[6 * j + 5, i] = 0.0, 0.0, 0.0
    for a in range(6):  # JᵀJ, packed lower triangle
        for b in range(a + 1):
            g = Gm[_gram_index(a, b)]
            for i in range(m):
                g[i] = 0.0
            for k in range(6):
                ja, jb = JL[6 * a + k], JL[6 * b + k]
                for i in range(m):
                    g[i] += ja[i] * jb[i]
    for i in range(m):  # ‖J‖_F², before the factor overwrites the diagonal
        lb[i] = Gm[0, i] + Gm[2, i] + Gm[5, i] + Gm[9, i] + Gm[14, i] + Gm[20, i]
    for a in range(6):  # Cholesky in place: a negative pivot gives NaN, and the scalar test decides
        for b in range(a + 1):
            g = Gm[_gram_index(a, b)]
            for k in range(b):
                ga, gb = Gm[_gram_index(a, k)], Gm[_gram_index(b, k)]
                for i in range(m):
                    g[i] -= ga[i] * gb[i]
            if a == b:
                for i in range(m):
                    g[i] = math.sqrt(g[i])
            else:
                gb = Gm[_gram_index(b, b)]
                for i in range(m):
                    g[i] = g[i] / gb[i]
    for i in range(m):
        f2 = lb[i]
        lb[i] = (Gm[0, i] * Gm[2, i] * Gm[5, i] * Gm[9, i] * Gm[14, i] * Gm[20, i]) / max(f2 * f2 * f2, 1e-300)
    return m


@nb.njit(**_JIT)
def polish(cand, ccount, reversed_, targets, base, chain, settings, limits, a, b_, outputs):
    """The solutions of targets ``a..b_`` (see the module text); returns nothing, fills the outputs.

    The arguments grouped as tuples (:func:`chain_arguments`, :func:`polish_settings`):
    ``chain = (columns, h, r, rev, M, table, D)``, the real chain (``table``, ``D``: in
    :func:`lane_table`'s form); ``settings = (steps, lam0, damped, middle, tight, final, reach, ptol,
    rtol, dup, singular)``; ``limits = (lower, upper, limit_tol)``; ``outputs = (Q, count, pe, re,
    within, sing)``. The candidates of up to
    :data:`LANE_TARGETS` targets (:data:`LANE_CANDIDATES` candidates) at a time first get
    :func:`lane_stage`, which maps and wraps them; a candidate it finds on its solution to ``tight``
    (most closed-form candidates) skips the scalar measure, and its singular flag comes from the
    lane bound where that decides. ``damped`` (a search from seeds): LM from
    λ = ``lam0`` with steps of at most 0.5 per joint, then ``middle`` undamped steps for a row that
    came within 1e-2 of a solution. A candidate whose first error (m + rad) is above ``reach`` is
    dropped unpolished."""
    columns, h, r, rev, M, table, D = chain
    steps, lam0, damped, middle, tight, final, reach, ptol, rtol, dup, singular = settings
    lower, upper, limit_tol = limits
    Q, count, pe, re, within, sing = outputs
    n = h.shape[0]
    C = Q.shape[1]
    dof = base.shape[1]
    work = scratch(n)
    F, W, O, J, e, R, out, A, bb, dq, trial, sn, cs = work
    real = (h, r, rev, M)
    x = np.empty(n)
    kept = np.empty((C, n))
    group = max(1, min(LANE_TARGETS, LANE_CANDIDATES // max(1, cand.shape[1])))
    w = group * cand.shape[1] + 8  # rows of the lane arrays not 4 KiB apart
    X, FL, S = np.empty((n, w)), np.empty((n, 12, w)), np.empty((2, n, w))
    TT, E, JL, Gm = np.empty((12, w)), np.empty((12, w)), np.empty((6 * n, w)), np.empty((21, w))
    lp, lq, lb = np.empty(w), np.empty(w), np.empty(w)
    lanes = (X, FL, S, TT, E, JL, Gm, lp, lq, lb)
    for g0 in range(a, b_, group):
        g1 = min(g0 + group, b_)
        lane_stage(cand, ccount, reversed_, targets, rev, table, D, g0, g1, lanes)
        lane = 0
        for t in range(g0, g1):
            T = targets[t]
            k = 0
            for c in range(ccount[t]):
                l = lane
                lane += 1
                if k >= C:
                    continue
                quick = lp[l] <= tight and lq[l] <= tight
                if lp[l] > reach or lp[l] + lq[l] > reach:  # (NaN: the scalar measure decides)
                    continue
                finite = True
                for j in range(n):  # mapped and wrapped by the lane stage
                    x[j] = X[j, l]
                    if not math.isfinite(x[j]):
                        finite = False
                if not finite:
                    continue
                if quick:  # on its solution already: the lane's values
                    p, q = lp[l], lq[l]
                else:
                    p, q = chain_error(real, x, T, work)
                    if p + q > reach:  # a least-squares point of a branch that does not exist (an exact family)
                        continue
                    if not (p <= tight and q <= tight):
                        cost = levenberg_marquardt(real, T, x, steps, lam0, damped, work)
                        if damped and cost < 1e-4 and middle > 0:  # near a solution: undamped steps
                            levenberg_marquardt(real, T, x, middle, 1e-12, False, work)
                        wrap(x, rev)
                        p, q = chain_error(real, x, T, work)
                    if p + q > tight and p < 10.0 * ptol and q < 10.0 * rtol and final > 0:
                        # near a solution but not on it to machine precision (a double root converges only linearly)
                        levenberg_marquardt(real, T, x, final, 1e-12, False, work)
                        wrap(x, rev)
                        p, q = chain_error(real, x, T, work)
                if not (p <= ptol and q <= rtol):
                    continue
                same = False
                for i in range(k):
                    if same_solution(x, kept[i], rev, dup):
                        same = True
                        break
                if same:
                    continue
                for j in range(n):
                    kept[k, j] = x[j]
                inside = True
                for j in range(dof):
                    Q[t, k, j] = base[t, j]
                for j in range(n):
                    Q[t, k, columns[j]] = x[j]
                for j in range(dof):
                    v = Q[t, k, j]
                    if v < lower[j] - limit_tol or v > upper[j] + limit_tol:
                        inside = False
                pe[t, k], re[t, k], within[t, k] = p, q, inside
                if quick and lb[l] > singular:
                    s = 0
                else:
                    if quick:  # the scalar frames at x, for the Jacobian
                        chain_fk(h, r, rev, M, x, F, W, O, sn, cs)
                    chain_jacobian(rev, F, W, O, J)
                    if n == 6 and det_bound(J, A) > singular:
                        s = 0
                    else:  # the bound does not decide: σ_min / σ_max itself
                        s = 1 if singular_ratio2(J, A) <= singular * singular else 0
                sing[t, k] = s
                k += 1
            count[t] = k
            for i in range(k, C):
                for j in range(dof):
                    Q[t, i, j] = np.nan
                pe[t, i], re[t, i], within[t, i], sing[t, i] = np.nan, np.nan, False, 0


@nb.njit(**_JIT)
def nominal(cand, ccount, targets, chain, tolerances, a, b_, count):
    """``count[t]``: the distinct candidates of target t (``a <= t < b_``) within the tolerances
    ``(position, rotation, duplicate)`` on ``chain = (h, r, rev, M)`` itself (no polish)."""
    h, r, rev, M = chain
    ptol, rtol, dup = tolerances
    n = h.shape[0]
    work = scratch(n)
    kept = np.empty((cand.shape[1], n))
    every = np.arange(n)
    for t in range(a, b_):
        k = 0
        for c in range(ccount[t]):
            finite = True
            for j in range(n):
                if not math.isfinite(cand[t, c, j]):
                    finite = False
            if not finite:
                continue
            p, q = chain_error(chain, cand[t, c], targets[t], work)
            if not (p <= ptol and q <= rtol):
                continue
            same = False
            for i in range(k):
                if close_rows(cand[t, c], kept[i], every, rev, dup):
                    same = True
                    break
            if not same:
                for j in range(n):
                    kept[k, j] = cand[t, c, j]
                k += 1
        count[t] = k


@nb.njit(**_JIT)
def _joint_copies(v, lo, hi, tol, periodic):
    """(first k, number of values) of joint value v's copies ``v + 2πk`` within [lo, hi] (to tol), or
    (0, 1 / 0) for a joint without copies (``periodic`` False: v itself when inside)."""
    if periodic:
        k0 = math.ceil((lo - tol - v) / (2.0 * math.pi))
        k1 = math.floor((hi + tol - v) / (2.0 * math.pi))
        return k0, max(k1 - k0 + 1, 0)
    return 0, 1 if (lo - tol <= v <= hi + tol) else 0


@nb.njit(**_JIT)
def copies(rows, cols, periodic, lower, upper, tol, count_only, starts, out):
    """Every ``q + 2πk`` copy of each row of ``rows`` (R, dof) within the limits: the columns ``cols``
    (the chain's joints, in order; ``periodic``: a revolute joint with finite limits that is not
    continuous) take each of their values inside ``[lower, upper]`` (to ``tol``, clipped to the limits),
    the first column varying slowest. ``count_only``: ``starts[i + 1]`` = the number of copies of row
    i; else the copies are written to ``out[starts[i]:starts[i + 1]]``."""
    n = cols.shape[0]
    k0 = np.empty(n, dtype=np.int64)
    m = np.empty(n, dtype=np.int64)
    for i in range(rows.shape[0]):
        total = 1
        for c in range(n):
            j = cols[c]
            k0[c], m[c] = _joint_copies(rows[i, j], lower[j], upper[j], tol, periodic[c])
            total *= m[c]
        if count_only:
            starts[i + 1] = total
            continue
        for s in range(total):
            o = starts[i] + s
            for j in range(rows.shape[1]):
                out[o, j] = rows[i, j]
            rest = s
            for c in range(n - 1, -1, -1):
                d = rest % m[c]
                rest //= m[c]
                j = cols[c]
                v = rows[i, j] + 2.0 * math.pi * (k0[c] + d) if periodic[c] else rows[i, j]
                out[o, j] = min(max(v, lower[j]), upper[j])
