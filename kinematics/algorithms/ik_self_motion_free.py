"""The best point of a redundant chain's self-motion that is free of self-collision.

:func:`~kinematics.algorithms.ik_self_motion.best` optimises an objective over the in-limit
self-motion; :func:`best_free` adds a filter ``free(Q)`` (R, dof) -> (R,) bool (the model's
allowed-collision matrix): where the unconstrained best point is free it is the answer; otherwise
every sample of every in-limit piece (the branches' samples and the pieces' ends) is checked in
one batch, the best free sample is taken, and golden-section search between its neighbouring
samples refines it, a colliding point scoring −∞ -- so where the optimum lies at a collision (the
objective still grows into it) the search closes in on the last free point.
"""

from __future__ import annotations

import numpy as np

from . import ik_self_motion as sm
from .ik_redundant import MATCH, PSI_TOLERANCE, SelfMotion

#: golden-section steps at most on the free best point (the bracket shrinks below PSI_TOLERANCE first)
MAX_STEPS = 80


def best_free(motion: SelfMotion, T_root: np.ndarray, objective: sm.Objective, free, pieces, branches) -> list:
    """Per target the best in-limit point free of self-collision (a
    :class:`~kinematics.algorithms.ik_self_motion.Best`), or None where the samples hold none."""
    found = sm.best(motion, T_root, objective, pieces, branches)
    out: list = list(found)
    todo = [n for n, b in enumerate(found) if b is not None and not free(b.q[None])[0]]
    if not todo:
        return out
    samples = {n: _samples(motion, objective, pieces[n], branches[n]) for n in todo}
    rows = [s for n in todo for s in samples[n]]
    ok = free(np.array([s[1] for s in rows])) if rows else np.zeros(0, bool)
    k = 0
    for n in todo:
        S = samples[n]
        flags = ok[k:k + len(S)]
        k += len(S)
        scores = np.where(flags, [s[2] for s in S], -np.inf)
        if not len(S) or not np.isfinite(scores.max()):
            out[n] = None
            continue
        i = int(np.argmax(scores))
        out[n] = _golden(motion, T_root[n], objective, free, S, i, pieces[n][S[i][3]].branch)
    return out


def _samples(motion, objective, pieces, branches) -> list:
    """``(ψ, q, value, piece)`` of every sample of every piece, in ψ order per piece."""
    out = []
    for p, piece in enumerate(pieces):
        psi, Q, M = sm.piece_samples(piece, branches[piece.branch])
        f = objective.values(motion, Q, M)
        out += [(float(x), q, float(v), p) for x, q, v in zip(psi, Q, f)]
    return out


def _golden(motion: SelfMotion, T: np.ndarray, objective, free, S: list, i: int, branch: int) -> sm.Best:
    """Golden-section search between the neighbours (on its piece, of ``branch``) of sample ``S[i]``."""
    x, q, f, piece = S[i]
    a = S[i - 1][0] if i > 0 and S[i - 1][3] == piece else x
    b = S[i + 1][0] if i + 1 < len(S) and S[i + 1][3] == piece else x
    pts = {x: (f, q)}
    cols = motion.chain.columns

    def value(p):
        if p not in pts:
            ref = pts[min(pts, key=lambda k: abs(k - p))][1]
            sl = motion.solve(T[None], np.array([p]), exact=True)
            Q = sl.q[0, :sl.count[0]]
            D = Q[:, cols] - ref[cols]
            D = np.abs(np.where(motion.chain.revolute, np.mod(D + np.pi, 2 * np.pi) - np.pi, D)).max(axis=1)
            k = int(np.argmin(D)) if len(D) else -1
            if k < 0 or D[k] >= MATCH:  # the branch is lost there
                pts[p] = (-np.inf, ref)
            else:
                s, m = Q[k], motion.margins(Q[k])
                ok = m.min() >= 0 and free(s[None])[0]
                pts[p] = (float(objective.values(motion, s, m)[0]) if ok else -np.inf, s)
        return pts[p][0]

    x1, x2 = b - sm.GOLDEN * (b - a), a + sm.GOLDEN * (b - a)
    for _ in range(MAX_STEPS):
        if b - a <= PSI_TOLERANCE:
            break
        if value(x1) >= value(x2):
            b, x2 = x2, x1
            x1 = b - sm.GOLDEN * (b - a)
        else:
            a, x1 = x1, x2
            x2 = a + sm.GOLDEN * (b - a)
    top = max(pts, key=lambda p: pts[p][0])
    f, q = pts[top]
    return sm.Best(objective.finish(motion, q), top, f, branch)
