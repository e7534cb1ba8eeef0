"""Every solution of chains with no subproblem family: the general 6R by the Raghavan-Roth /
Manocha-Canny elimination (an eigenvalue problem that misses no root), and the short chains
(2R / 3R planar, SCARA, RPR) in closed form.

**General 6R.** With ``g = T M⁻¹ = e₁ ... e₆`` (``eⱼ = exp([Sⱼ] qⱼ)``, the chain's own
zero-configuration screws, no DH table needed) the point ``r₆`` and the direction ``h₆`` of axis 6
are fixed by ``e₆``, so

    e₃ e₄ e₅ (r₆) = e₂⁻¹ e₁⁻¹ g (r₆),        R₃ R₄ R₅ h₆ = R₂ᵀ R₁ᵀ R_g h₆.

Measured from the point ``r₃`` of axis 3 these are ``p`` and ``l`` (3 equations each); with
``p·p``, ``p·l``, ``p × l`` and ``(p·p) l − 2 (p·l) p`` they are Raghavan and Roth's 14
equations. Each side is linear in the products ``[s₄, c₄, 1] ⊗ [s₅, c₅, 1]`` (left, with
coefficients linear in ``c₃, s₃``) and ``[s₁, c₁, 1] ⊗ [s₂, c₂, 1]`` (right, coefficients fixed by
the target): ``P(θ₃) m₄₅ = Q m₁₂``. The coefficient matrices are read off the chain by exact
linear fits on sample angles (the structure is an identity; the fit's residual is checked), the 8
unknowns of ``m₁₂`` are eliminated with the left null space of ``Q`` (6 x 14), half-angle
tangents ``x₄, x₅`` and one multiplication by ``x₄`` give a 12 x 12 matrix ``M(x₃) = M₀ + M₁ x₃
+ M₂ x₃²`` whose determinant (degree 16 once the spurious factor ``(1 + x₃²)⁴`` is gone) vanishes
at every solution. Its roots are the eigenvalues of the 24 x 24 companion pencil
(``numpy.linalg.eigvals``; the reversed polynomial's when that is the better conditioned), so none
is missed; each real one gives ``θ₄, θ₅`` from the null vector
of ``M(x₃)``, ``θ₁, θ₂`` from the 14 equations by least squares, ``θ₆`` from the orientation
(subproblem 1). The angles are offset by fixed irrational-looking shifts before the half-angle
substitution so that no solution sits at ``x = ∞``. Every candidate is then polished by Newton
steps on the real FK and checked there (:mod:`kinematics.algorithms.ik_all`). Where the chain's
geometry makes the elimination degenerate (two consecutive axes meeting can make the 8 unknowns
dependent), the caller runs it on the reversed chain, and a target where it degenerates still is
solved on a cyclic shift of the loop (:func:`_shifted`).

>>> from kinematics.io.dh_table import model_from_table, table_from_dict
>>> from kinematics.engine.poe import compile_model
>>> from kinematics.algorithms.ik_families import reduce_chain
>>> rows = [{"type": "revolute", "a": a, "alpha": al, "d": d, "theta": 0.0} for a, al, d in
...         [(0.3, 0.7, 0.1), (0.2, 1.1, 0.2), (0.25, 0.5, 0.15), (0.1, 0.9, 0.3), (0.3, 1.2, 0.1), (0.2, 0.6, 0.1)]]
>>> model = model_from_table(table_from_dict({"name": "r6", "convention": "standard", "joints": rows}))
>>> link = model.leaf_links[0]
>>> q = np.array([0.3, -0.2, 0.9, 1.4, -0.6, 2.0])
>>> T = compile_model(model).fk(q[None], [link])[:, 0]
>>> cand, count = general_6r_candidates(reduce_chain(model, link), T)
>>> int(count[0]) <= 16 and bool(np.abs(np.angle(np.exp(1j * (cand[0, :count[0]] - q)))).max(axis=1).min() < 1e-6)
True

**Short chains.** Every axis parallel to ``h`` (prismatic joints along ``h`` commute with the
rotations, so they only set the height along ``h``): the point on the last revolute axis (3R,
SCARA) or the link's origin (2R) is placed by two rotations in the plane (the law of cosines:
two solutions), the last revolute angle gives the orientation. RPR (revolute, prismatic along
the third axis, revolute): the orientation gives ``q₁`` (subproblem 1 on ``h₃``) and ``q₃``, the
position ``q₂``: one solution.

**A slide and three parallel axes** (``prismatic_three_parallel``, Wen's Rhino arm: joint 1
prismatic, axes 3 ∥ 4 ∥ 5): subproblems 2 and 1 for the orientation, a linear equation for the
slide, subproblems 3 and 1 in the plane of the parallel axes: up to four solutions
(:func:`_prismatic_three_parallel`).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ..engine import subproblems

#: a :class:`kinematics.algorithms.ik_families.Chain` (its ``n``, ``h``, ``r``, ``revolute``, ``M``,
#: ``mimic``); not imported, since the family detection imports this module
Chain = Any

#: the angle shifts of θ3, θ4, θ5 before the half-angle substitution (no root at x = ∞)
SHIFT3, SHIFT4, SHIFT5 = 0.5173, -0.3311, 0.7219
#: an eigenvalue is taken as real when |Im x| <= this times (1 + |x|) (near-double roots included)
REAL_TOLERANCE = 1e-5
#: both end matrices of the pencil worse conditioned than this: the elimination degenerates here
DEGENERATE_CONDITION = 1e12
#: largest residual of the structure fits (relative to the coefficients' size)
FIT_TOLERANCE = 1e-9


def _rot(h: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(K, 3, 3) rotations by q (K,) about the unit axis h (3,) (Rodrigues)."""
    K = np.array([[0.0, -h[2], h[1]], [h[2], 0.0, -h[0]], [-h[1], h[0], 0.0]])
    c, s = np.cos(q)[:, None, None], np.sin(q)[:, None, None]
    return np.eye(3) + s * K + (1 - c) * (K @ K)


def _move(h, r, q, x):
    """Points x (K, 3) moved by the rotations q (K,) about the axis (h, r)."""
    return np.einsum("kij,kj->ki", _rot(h, q), x - r) + r


def _fourteen(p: np.ndarray, l: np.ndarray) -> np.ndarray:
    """Raghavan and Roth's 14 quantities (K, 14) of p, l (K, 3)."""
    pp = np.sum(p * p, axis=1, keepdims=True)
    pl = np.sum(p * l, axis=1, keepdims=True)
    return np.concatenate([p, l, pp, pl, np.cross(p, l), pp * l - 2 * pl * p], axis=1)


def _basis(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(K, 9): [s_a, c_a, 1] ⊗ [s_b, c_b, 1]."""
    u = np.stack([np.sin(a), np.cos(a), np.ones_like(a)], axis=1)
    v = np.stack([np.sin(b), np.cos(b), np.ones_like(b)], axis=1)
    return np.einsum("ki,kj->kij", u, v).reshape(len(a), 9)


_GRID = np.random.default_rng(7).uniform(-np.pi, np.pi, size=(40, 2))
_GRID_BASIS = _basis(_GRID[:, 0], _GRID[:, 1])
_GRID_PINV = np.linalg.pinv(_GRID_BASIS)
#: half-angle form: (1 + x²)[s, c, 1] = [2x, 1 − x², 1 + x²], coefficients of x⁰, x¹, x²
_HALF = np.array([[0.0, 2.0, 0.0], [1.0, 0.0, -1.0], [1.0, 0.0, 1.0]])
#: m45 (kron of [s4,c4,1], [s5,c5,1]) times (1+x4²)(1+x5²) -> coefficients of x4^i x5^j (i, j <= 2)
_HALF2 = np.einsum("ai,bj->abij", _HALF, _HALF).reshape(9, 9)


class _Model6R:
    """The target-independent part of the elimination for one chain: the left side P(θ3) = P0 + c3 Pc + s3 Ps;
    and what was learnt of the chain: ``applies`` (:func:`applies`, None until asked) and
    ``shift_hint``, the cyclic shift of the loop that last gave a target a non-degenerate elimination
    (:func:`_shifted` tries it first: an order, not a result)."""

    def __init__(self, chain: Chain):
        h, r = chain.h, chain.r
        self.h, self.r, self.M = h, r, chain.M
        self.applies: bool | None = None
        self.shift_hint = 1
        self.fit_residual = 0.0
        K = len(_GRID)
        blocks = []
        for t3 in (0.0, np.pi / 2, np.pi):  # P(θ3) at three values -> P0, Pc, Ps
            q3 = np.full(K, t3)
            q4, q5 = _GRID[:, 0] + SHIFT4, _GRID[:, 1] + SHIFT5
            x = _move(h[4], r[4], q5, np.repeat(r[5][None], K, 0))
            x = _move(h[3], r[3], q4, x)
            x = _move(h[2], r[2], q3, x)
            lv = np.einsum("kij,kj->ki", _rot(h[2], q3) @ _rot(h[3], q4) @ _rot(h[4], q5), np.repeat(h[5][None], K, 0))
            F = _fourteen(x - r[2], lv)  # (K, 14)
            C = _GRID_PINV @ F           # (9, 14)
            self.fit_residual = max(self.fit_residual, float(np.abs(_GRID_BASIS @ C - F).max()))
            blocks.append(C.T)
        P_0, P_half, P_pi = blocks  # c3 = 1, s3 = 0 | c3 = 0, s3 = 1 | c3 = −1, s3 = 0
        self.P0 = (P_0 + P_pi) / 2
        self.Pc = (P_0 - P_pi) / 2
        self.Ps = P_half - self.P0
        self.scale = max(1.0, float(np.abs(np.concatenate([self.P0, self.Pc, self.Ps])).max()))

    def right(self, G: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The right sides of N targets g (N, 4, 4): Q9 (N, 14, 9) with Q9 m12 = the 14 quantities, and
        each fit's residual (N,)."""
        h, r = self.h, self.r
        R1, R2 = _rot(h[0], -_GRID[:, 0]), _rot(h[1], -_GRID[:, 1])  # (K, 3, 3)
        x = np.einsum("nij,j->ni", G[:, :3, :3], r[5]) + G[:, :3, 3]   # g(r6), (N, 3)
        x = np.einsum("kij,nj->nki", R1, x - r[0]) + r[0]             # e1⁻¹, then e2⁻¹: (N, K, 3)
        x = np.einsum("kij,nkj->nki", R2, x - r[1]) + r[1]
        lv = np.einsum("kij,nj->nki", R2 @ R1, np.einsum("nij,j->ni", G[:, :3, :3], h[5]))
        N, K = x.shape[:2]
        F = _fourteen((x - r[2]).reshape(-1, 3), lv.reshape(-1, 3)).reshape(N, K, 14)
        C = np.einsum("bk,nkf->nbf", _GRID_PINV, F)                  # (N, 9, 14)
        res = np.abs(np.einsum("kb,nbf->nkf", _GRID_BASIS, C) - F).max(axis=(1, 2))
        return C.transpose(0, 2, 1), res


def _big(Sig: np.ndarray) -> np.ndarray:
    """(N, 6, 9) over x4^i x5^j (i <= 2) -> (N, 12, 12) over x4^i x5^j (i <= 3): the rows, and the rows times x4."""
    out = np.zeros((len(Sig), 12, 4, 3))
    S3 = Sig.reshape(-1, 6, 3, 3)
    out[:, :6, :3] = S3
    out[:, 6:, 1:] = S3
    return out.reshape(-1, 12, 12)


def _real_roots(M0: np.ndarray, M1: np.ndarray, M2: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
    """For each n, the real x (within :data:`REAL_TOLERANCE`) with det(M0 + M1 x + M2 x²) = 0 (M_k: (N, 12, 12)):
    the eigenvalues of the companion matrix [[0, I], [−M2⁻¹M0, −M2⁻¹M1]] (24 x 24), or of the reversed
    polynomial's (roots 1/x) where M0 is the better conditioned of M0, M2; and a (N,) mask of the
    degenerate ones (both ends ill-conditioned: det M(x) may vanish identically)."""
    N = len(M0)
    c0, c2 = np.linalg.cond(M0), np.linalg.cond(M2)
    degenerate = ~(np.minimum(c0, c2) <= DEGENERATE_CONDITION)
    reverse = c0 < c2
    lead = np.where(reverse[:, None, None], M0, M2)
    last = np.where(reverse[:, None, None], M2, M0)
    lead[degenerate] = np.eye(12)
    comp = np.zeros((N, 24, 24))
    comp[:, :12, 12:] = np.eye(12)
    comp[:, 12:, :12] = -np.linalg.solve(lead, last)
    comp[:, 12:, 12:] = -np.linalg.solve(lead, M1)
    lam = np.linalg.eigvals(comp)
    out = []
    for n in range(N):
        x = lam[n][np.abs(lam[n].imag) <= REAL_TOLERANCE * (1 + np.abs(lam[n]))].real
        if reverse[n]:
            x = 1.0 / x[np.abs(x) > 1e-14]
        out.append(x)
    return out, degenerate


def _solve(m: _Model6R, G: np.ndarray) -> list[np.ndarray | None]:
    """For each target g = T M⁻¹ (N, 4, 4): its candidates (K, 6), or None where the elimination degenerates."""
    N = len(G)
    Q9, res = m.right(G)
    bad = res > FIT_TOLERANCE * np.maximum(m.scale, np.abs(Q9).max(axis=(1, 2)))
    Q = Q9[:, :, [0, 1, 3, 4, 2, 5, 6, 7]]   # m12 columns without the constant: s1s2 s1c2 c1s2 c1c2 s1 c1 s2 c2
    P0 = np.repeat(m.P0[None], N, 0)
    P0[:, :, 8] -= Q9[:, :, 8]                # P(θ3) m45 − const = Q m12
    U, S, _ = np.linalg.svd(Q)
    bad |= S[:, -1] < 1e-10 * S[:, 0]         # the 8 unknowns of the right side dependent: no elimination
    Nl = U[:, :, 8:].transpose(0, 2, 1)       # (N, 6, 14): Nl Q = 0
    Qpinv = np.linalg.pinv(Q)                 # (N, 8, 14)
    S0, Sc, Ss = Nl @ P0, Nl @ m.Pc, Nl @ m.Ps  # Σ(θ3) = S0 + c3 Sc + s3 Ss, (N, 6, 9)
    cd, sd = np.cos(SHIFT3), np.sin(SHIFT3)  # θ3 = φ + SHIFT3
    A, B = cd * Sc + sd * Ss, -sd * Sc + cd * Ss
    # (1 + x²) Σ = (S0 + A) + 2 B x + (S0 − A) x², then in x4^i x5^j (i, j <= 2)
    M0, M1, M2 = _big((S0 + A) @ _HALF2), _big(2 * B @ _HALF2), _big((S0 - A) @ _HALF2)
    roots, degenerate = _real_roots(M0, M1, M2)
    bad |= degenerate
    owner = np.concatenate([np.full(len(x), n, dtype=np.intp) for n, x in enumerate(roots)])
    x3 = np.concatenate(roots)
    keep = ~bad[owner]
    owner, x3 = owner[keep], x3[keep]
    h = m.h
    if len(x3):
        phi3 = 2 * np.arctan(x3) + SHIFT3
        Mx = M0[owner] + M1[owner] * x3[:, None, None] + M2[owner] * (x3 * x3)[:, None, None]
        w = np.linalg.svd(Mx)[2][:, -1].reshape(-1, 4, 3)  # ∝ x4^i x5^j
        den4, num4 = w[:, :3].reshape(-1, 9), w[:, 1:].reshape(-1, 9)
        x4 = np.sum(num4 * den4, axis=1) / np.maximum(np.sum(den4 * den4, axis=1), 1e-300)
        den5, num5 = w[:, :, :2].reshape(-1, 8), w[:, :, 1:].reshape(-1, 8)
        x5 = np.sum(num5 * den5, axis=1) / np.maximum(np.sum(den5 * den5, axis=1), 1e-300)
        phi4, phi5 = 2 * np.arctan(x4), 2 * np.arctan(x5)
        m45 = _basis(phi4, phi5)
        c3, s3 = np.cos(phi3)[:, None, None], np.sin(phi3)[:, None, None]
        rhs = np.einsum("rij,rj->ri", P0[owner] + c3 * m.Pc + s3 * m.Ps, m45)
        m12 = np.einsum("rij,rj->ri", Qpinv[owner], rhs)
        q = np.stack([np.arctan2(m12[:, 4], m12[:, 5]), np.arctan2(m12[:, 6], m12[:, 7]), phi3,
                      phi4 + SHIFT4, phi5 + SHIFT5, np.zeros(len(x3))], axis=1)
        # θ6 from the orientation: R6 = (R1 ... R5)ᵀ R_g, a rotation about h6 (subproblem 1 on a vector ⊥ h6)
        R = _rot(h[0], q[:, 0])
        for j in range(1, 5):
            R = R @ _rot(h[j], q[:, j])
        R6 = np.einsum("rji,rjk->rik", R, G[owner, :3, :3])
        v = np.cross(h[5], [1.0, 0.0, 0.0])
        if np.linalg.norm(v) < 0.5:
            v = np.cross(h[5], [0.0, 1.0, 0.0])
        v /= np.linalg.norm(v)
        wv = R6 @ v
        q[:, 5] = np.arctan2(np.cross(v, wv) @ h[5], wv @ v)
        q = np.mod(q + np.pi, 2 * np.pi) - np.pi
    else:
        q = np.zeros((0, 6))
    return [None if bad[n] else q[owner == n] for n in range(N)]


def general_6r_candidates(chain: Chain, T_root: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N, 16 at least, 6) candidate joint values of a 6R chain (chain order) for targets T_root
    (N, 4, 4, root frame) and their counts (N,): the real roots of the 16-degree elimination, each
    back-substituted (not yet polished). A chain or target where the elimination degenerates
    gets count −1 (the caller searches there; see :func:`usable`)."""
    T_root = np.asarray(T_root, dtype=float).reshape(-1, 4, 4)
    m = _model(chain)
    G = np.einsum("nij,jk->nik", T_root, np.linalg.inv(chain.M))
    # a non-finite or absurd target has no solution (and would stop the eigen-solvers): no candidate
    fine = np.flatnonzero(np.all(np.isfinite(G) & (np.abs(G) < 1e12), axis=(1, 2)))
    sols: list = [np.zeros((0, 6)) for _ in range(len(T_root))]
    for n, s in zip(fine, _solve(m, G[fine]) if fine.size else []):
        sols[n] = s if s is not None else _shifted(chain, G[n])
    K = max(16, max((len(s) for s in sols if s is not None), default=0))
    Q = np.zeros((len(T_root), K, 6))
    count = np.zeros(len(T_root), dtype=np.int64)
    for n, s in enumerate(sols):
        count[n] = -1 if s is None else len(s)
        if s is not None and len(s):
            Q[n, :len(s)] = s
    return Q, count


def _shifted(chain: Chain, G: np.ndarray) -> np.ndarray | None:
    """The candidates (K, 6) of one target ``g`` (4, 4) by the elimination on a cyclic shift of the
    loop, or None where every shift degenerates too.

    ``e₁ ⋯ e₆ = g`` is also ``e_{k+1} ⋯ e₆ · e₁' ⋯ e_k' = g`` with ``e_j' = g⁻¹ e_j g`` (the screw
    ``Ad_{g⁻¹} S_j``: axis ``R_gᵀ h_j`` through ``g⁻¹ r_j``), a 6R chain of the same joint values in
    the order ``k+1 .. 6, 1 .. k``. A chain whose own geometry makes the elimination degenerate
    forwards and reversed (two consecutive axes meeting, a Jaco-like wrist) is generic in some shift,
    because the shifted chain's link from joint 6 to joint 1 is the target's."""
    R, p = G[:3, :3], G[:3, 3]
    own = _model(chain)
    hint = own.shift_hint
    for k in [hint] + [k for k in range(1, 6) if k != hint]:  # the shift that worked last first
        order = list(range(k, 6)) + list(range(k))
        h = np.concatenate([chain.h[k:], chain.h[:k] @ R])
        r = np.concatenate([chain.r[k:], (chain.r[:k] - p) @ R])
        shifted = replace(chain, h=h, r=r, M=np.eye(4), joints=tuple(chain.joints[i] for i in order),
                          columns=chain.columns[order], revolute=chain.revolute[order])
        m = _Model6R(shifted)
        if m.fit_residual > FIT_TOLERANCE * m.scale:
            continue
        sols = _solve(m, G[None])[0]
        if sols is not None:
            own.shift_hint = k
            q = np.empty_like(sols)
            q[:, order] = sols
            return q
    return None


def applies(chain: Chain) -> bool:
    """:func:`usable` on the chain itself or on the cyclic shifts of its loop (kept per chain): the
    elimination gives every solution of its targets (a target where it still degenerates: count −1)."""
    m = _model(chain)
    if m.applies is None:
        m.applies = usable(chain) or usable(chain, shifts=True)
    return m.applies


_CACHE: dict[int, tuple[Chain, _Model6R]] = {}


def _model(chain: Chain) -> _Model6R:
    hit = _CACHE.get(id(chain))
    if hit is not None and hit[0] is chain:
        return hit[1]
    m = _Model6R(chain)
    if len(_CACHE) > 32:
        _CACHE.clear()
    _CACHE[id(chain)] = (chain, m)
    return m


def usable(chain: Chain, trials: int = 3, shifts: bool = False) -> bool:
    """True when the elimination applies to the 6R ``chain``: six revolute joints, the structure fits
    exact, and on ``trials`` poses of random configurations nothing degenerates and the generating
    configuration is among the candidates (a chain of special geometry -- e.g. two axes meeting --
    can make the 8 unknowns of the right side dependent). ``shifts``: the same test of the
    elimination on the cyclic shifts of the loop (:func:`_shifted`), for a chain where it
    degenerates forwards and reversed."""
    if chain.n != 6 or not bool(np.all(chain.revolute)) or chain.mimic:
        return False
    m = _model(chain)
    if not shifts and m.fit_residual > FIT_TOLERANCE * m.scale:
        return False
    rng = np.random.default_rng(11)
    for _ in range(trials):
        q = rng.uniform(-np.pi, np.pi, 6)
        G = np.eye(4)
        for j in range(6):
            E = np.eye(4)
            E[:3, :3] = _rot(chain.h[j], q[j:j + 1])[0]
            E[:3, 3] = chain.r[j] - E[:3, :3] @ chain.r[j]
            G = G @ E
        sols = _shifted(chain, G) if shifts else _solve(m, G[None])[0]
        if sols is None or not len(sols) or np.abs(np.angle(np.exp(1j * (np.array(sols) - q)))).max(axis=1).min() > 1e-6:
            return False
    return True


# ---------------------------------------------------------------------- short chains
#: the kernels of this module (``Family.kernel``); those that also solve a position alone
KERNELS = ("general_6r", "planar_2r", "planar_3r", "rpr", "prismatic_three_parallel")
POSITION_KERNELS = ("planar_2r",)


def _angle_about(h: np.ndarray, R: np.ndarray) -> float:
    """The angle of R (3, 3) about the unit axis h, read on a vector ⊥ h (subproblem 1)."""
    v = np.cross(h, [1.0, 0.0, 0.0])
    if np.linalg.norm(v) < 0.5:
        v = np.cross(h, [0.0, 1.0, 0.0])
    v /= np.linalg.norm(v)
    w = R @ v
    return float(np.arctan2(h @ np.cross(v, w), v @ w))


def short_kernel(ch: Chain) -> str:
    """Which short-chain closed form solves ``ch`` ("" when none): ``planar_2r`` (two revolute axes
    parallel, at most one prismatic joint along them), ``planar_3r`` (three), ``rpr``."""
    rev = np.flatnonzero(ch.revolute)
    pri = np.flatnonzero(~ch.revolute)
    ref = ch.h[rev[0]] if rev.size else None
    if ref is not None and all(np.linalg.norm(np.cross(ref, h)) < 1e-9 for h in ch.h) and pri.size <= 1:
        P = np.eye(3) - np.outer(ref, ref)
        if rev.size in (2, 3) and np.linalg.norm(P @ (ch.r[rev[1]] - ch.r[rev[0]])) > 1e-9:
            return "planar_2r" if rev.size == 2 else "planar_3r"
        return ""
    if ch.n == 3 and ch.revolute.tolist() == [True, False, True] \
            and np.linalg.norm(np.cross(ch.h[1], ch.h[2])) < 1e-9 and np.linalg.norm(np.cross(ch.h[0], ch.h[2])) > 1e-6:
        return "rpr"
    return ""


def _planar(ch: Chain, T: np.ndarray, position_only: bool) -> list[np.ndarray]:
    """Candidates of a planar chain (2R / 3R, prismatic joints along the axes) for one target T (4, 4)."""
    rev = np.flatnonzero(ch.revolute)
    pri = np.flatnonzero(~ch.revolute)
    h = ch.h[rev[0]]
    sigma = np.sign(ch.h[rev] @ h)  # axis j = sigma_j h
    G = T @ np.linalg.inv(ch.M)
    if len(rev) == 3:
        x0 = ch.r[rev[2]]
        xs = G[:3, :3] @ x0 + G[:3, 3]  # the last revolute axis' point is moved by the first two only
    else:
        x0, xs = ch.M[:3, 3], T[:3, 3]
    q = np.zeros(ch.n)
    if pri.size:  # the height along h: set by the prismatic joint (it commutes with the rotations)
        dh = float(h @ ch.h[pri[0]])
        q[pri[0]] = float(h @ (xs - x0)) / dh
    P = np.eye(3) - np.outer(h, h)
    ra, rb = ch.r[rev[0]], ch.r[rev[1]]
    u, v, w = P @ (x0 - rb), P @ (rb - ra), P @ (xs - ra)
    A, B = float(v @ u), float(v @ np.cross(h, u))
    C = (w @ w - u @ u - v @ v) / 2
    rho = np.hypot(A, B)
    if rho < 1e-300 or abs(C) > rho * (1 + 1e-9):
        return []
    base, spread = np.arctan2(B, A), np.arccos(np.clip(C / rho, -1.0, 1.0))
    out = []
    for beta in {base + spread, base - spread} if spread > 0 else {base}:
        z = np.cos(beta) * u + np.sin(beta) * np.cross(h, u) + v
        alpha = np.arctan2(h @ np.cross(z, w), z @ w)
        qq = q.copy()
        qq[rev[0]], qq[rev[1]] = sigma[0] * alpha, sigma[1] * beta
        if len(rev) == 3:
            phi = _angle_about(h, G[:3, :3])
            qq[rev[2]] = sigma[2] * (phi - alpha - beta)
        out.append(qq)
    return out


def _rpr(ch: Chain, T: np.ndarray) -> list[np.ndarray]:
    """The candidate of an RPR chain (axis 3 along the prismatic direction, axis 1 not) for one pose T."""
    G = T @ np.linalg.inv(ch.M)
    h1, d2, h3 = ch.h
    a, b = h3, G[:3, :3] @ h3  # R1(q1) R3(q3) h3 = R1(q1) h3: subproblem 1 about h1
    ap, bp = a - (h1 @ a) * h1, b - (h1 @ b) * h1
    if np.linalg.norm(ap) < 1e-12 or abs(h1 @ a - h1 @ b) > 1e-6:
        return []
    q1 = float(np.arctan2(h1 @ np.cross(ap, bp), ap @ bp))
    R1 = _rot(h1, np.array([q1]))[0]
    q3 = _angle_about(h3, R1.T @ G[:3, :3])
    xs = G[:3, :3] @ ch.r[2] + G[:3, 3]  # the point of axis 3: e1 e2 (r3)
    q2 = float(d2 @ (R1.T @ (xs - ch.r[0]) + ch.r[0] - ch.r[2]))
    return [np.array([q1, q2, q3])]


def prismatic_parallel(ch: Chain) -> bool:
    """True for a ``prismatic_three_parallel`` chain (Wen's Rhino arm): joint 1 prismatic, joints 2-6
    revolute, axes 3 ∥ 4 ∥ 5, axes 2 and 6 not parallel to them, and the slide's height along axis 3
    (after axis 2 turns it) not zero for every q2 (else the slide would not be fixed by the pose)."""
    if ch.n != 6 or ch.mimic or ch.revolute.tolist() != [False, True, True, True, True, True]:
        return False
    h = ch.h
    if any(np.linalg.norm(np.cross(h[2], h[j])) > 1e-9 for j in (3, 4)):
        return False
    if min(np.linalg.norm(np.cross(h[2], h[j])) for j in (1, 5)) < 1e-3:
        return False
    a, k, x = h[0], h[1], h[2]  # x · R(k, −q2) a = A cos q2 + B sin q2 + C
    A, B, C = x @ a - (k @ a) * (k @ x), -(x @ np.cross(k, a)), (k @ a) * (k @ x)
    return max(abs(A), abs(B), abs(C)) > 1e-6


def _prismatic_three_parallel(ch: Chain, T: np.ndarray) -> list[np.ndarray] | None:
    """The candidates (up to 4) of a ``prismatic_three_parallel`` chain for one pose T (4, 4); None where
    the slide is not fixed by the pose (the caller searches there).

    With ``g = T M⁻¹`` and axes 3, 4, 5 along ``h₃`` (joint j turning by ``φ_j = σ_j q_j`` about it):
    the orientation ``R₂(q₂) R(h₃, φ₃ + φ₄ + φ₅) R₆(q₆) = R_g`` gives ``−q₂`` and ``θ = φ₃ + φ₄ + φ₅``
    by subproblem 2 on ``h₆`` and ``q₆`` by subproblem 1; rotations about ``h₃`` keep the height along
    it, so for the point ``c`` of axis 6, ``h₃·e₂⁻¹(g c − d₁ h₁) = h₃·c`` is linear in the slide
    ``d₁``; then ``y = e₃e₄(r₅) = e₂⁻¹(g c − d₁ h₁) − R(h₃, θ)(c − r₅)`` gives ``φ₄`` by subproblem 3
    (its distance to ``r₃``), ``φ₃`` by subproblem 1, and ``φ₅ = θ − φ₃ − φ₄``."""
    G = T @ np.linalg.inv(ch.M)
    h, r = ch.h, ch.r
    x = h[2]
    sigma = np.sign(h[2:5] @ x)
    c = r[5]
    gc = G[:3, :3] @ c + G[:3, 3]
    t1, t2, n2, flag = subproblems.sp2(G[:3, :3] @ h[5], h[5], h[1], x)
    if flag == subproblems.DEGENERATE:
        return None
    out = []
    for b in range(n2):
        q2, theta = -t1[b], t2[b]
        R2t = _rot(h[1], np.array([-q2]))[0]
        R3 = _rot(x, np.array([theta]))[0]
        q6 = _angle_about(h[5], R3.T @ R2t @ G[:3, :3])
        den = x @ (R2t @ h[0])
        if abs(den) < 1e-9:
            return None
        d1 = (x @ r[1] + x @ (R2t @ (gc - r[1])) - x @ c) / den
        xp = r[1] + R2t @ (gc - d1 * h[0] - r[1])
        y = xp - R3 @ (c - r[4])
        t4, n4, _ = subproblems.sp3(r[4] - r[3], r[2] - r[3], x, float(np.linalg.norm(y - r[2])))
        for k in range(n4):
            e4 = r[3] + _rot(x, np.array([t4[k]]))[0] @ (r[4] - r[3])
            phi3, _ = subproblems.sp1(e4 - r[2], y - r[2], x)
            phi = np.array([phi3, t4[k], theta - phi3 - t4[k]])
            out.append(np.concatenate([[d1, q2], sigma * phi, [q6]]))
    return out


def candidates(kernel: str, chain: Chain, T_root: np.ndarray, position_only: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(N, K, n) candidate values of the chain's joints (chain order) and counts (N,; −1 where the
    kernel does not apply to that target) for targets T_root (N, 4, 4, root frame) by this module's
    ``kernel`` (one of :data:`KERNELS`)."""
    if kernel == "general_6r":
        return general_6r_candidates(chain, T_root)
    T_root = np.asarray(T_root, dtype=float).reshape(-1, 4, 4)
    if kernel == "prismatic_three_parallel":
        sols = [_prismatic_three_parallel(chain, T) if np.all(np.isfinite(T)) else [] for T in T_root]
    else:
        sols = [_rpr(chain, T) if kernel == "rpr" else _planar(chain, T, position_only) for T in T_root]
    Q = np.zeros((len(T_root), max([2] + [len(s) for s in sols if s]), chain.n))
    count = np.zeros(len(T_root), dtype=np.int64)
    for n, s in enumerate(sols):
        count[n] = -1 if s is None else len(s)
        if s:
            Q[n, :len(s)] = np.array(s)
    return Q, count


def family_candidates(fam: Any, T_root: np.ndarray, position_only: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """:func:`candidates` of a :class:`~kinematics.algorithms.ik_families.Family` with one of this module's
    kernels: on its ``ideal`` chain, and for a ``reversed`` family on the reversed chain (targets
    inverted, then ``q_k = −q'_{n−1−k}``)."""
    if not fam.reversed:
        return candidates(fam.kernel, fam.chain, T_root, position_only)
    T_root = np.asarray(T_root, dtype=float).reshape(-1, 4, 4)
    Q, count = candidates(fam.kernel, fam.ideal, np.linalg.inv(T_root), position_only)
    return -Q[:, :, ::-1], count
