"""Identifiability: which parameter combinations the measured configurations determine.

The identification Jacobian stacks, for every measurement, the derivative of the residual
(the predicted minus the measured position, and for poses the rotation error weighted by a
length) with respect to every parameter of the :class:`~.errors_model.ErrorModel`
(:func:`residual_and_jacobian`, analytic). Its numerical rank, from the singular values of the
column-equilibrated matrix, is the number of combinations the data determine: for generic
configurations the complete-and-minimal count ``4R + 2P + 6`` with poses measured and
``4R + 2P + 3`` with positions (R revolute, P prismatic joints on the path; base and tool
estimated).

Which parameters stand for those combinations is chosen in a fixed order of preference -- the
base, the tool, the joint zero offsets, then the joint origins from the last joint to the first
-- a column joining the chosen ones when it raises their rank. Every other parameter is named
``unidentifiable`` with the reason read off its column: zero (unobservable from positions, or
not moving the measured frame), or a combination of the base's columns (absorbed by the base
frame), of its own joint's zero offset, of the next joint's (or the tool's) columns (absorbed by
the next joint), or of other parameters.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...spatial.lie import so3_log
from .errors_model import ErrorModel, so3_left_jacobian_inverse

#: relative singular value below which a direction counts as undetermined
RANK_TOLERANCE = 1e-9


def residual_and_jacobian(em: ErrorModel, Q: np.ndarray, x: np.ndarray, measured: np.ndarray,
                          rotation_weight: float = 1.0, want_jacobian: bool = True):
    """Residuals (N, d) and their Jacobian (N, d, p) at parameters x (d = 3 positions, 6 poses).

    ``measured``: positions (N, 3) or poses (N, 4, 4) in the device frame. The residual is
    ``p_pred - p_meas`` (metres), for poses followed by ``rotation_weight * log(R_pred R_meas^T)``
    (radians times a length in metres: 1 m per radian weighs 1 mrad like 1 mm).
    """
    if want_jacobian:
        T, cols = em.jacobian(Q, x)
    else:
        T, cols = em.predict(Q, x), None
    if measured.ndim == 2:
        r = T[:, :3, 3] - measured
        return r, (None if cols is None else cols[:, :3, :])
    phi = so3_log(T[:, :3, :3] @ np.swapaxes(measured[:, :3, :3], 1, 2))
    r = np.concatenate([T[:, :3, 3] - measured[:, :3, 3], rotation_weight * phi], axis=1)
    if cols is None:
        return r, None
    J_rot = rotation_weight * (so3_left_jacobian_inverse(phi) @ cols[:, 3:, :])
    return r, np.concatenate([cols[:, :3, :], J_rot], axis=1)


def singular_values(A: np.ndarray, vectors: bool = False):
    """Singular values (descending) of a tall A (m, p), through its QR factor (several times faster
    than an SVD of A itself); with ``vectors`` also ``Vt`` (p, p)."""
    R = np.linalg.qr(A, mode="r") if A.shape[0] > A.shape[1] else A
    if vectors:
        _, s, Vt = np.linalg.svd(R, full_matrices=False)
        return s, Vt
    return np.linalg.svd(R, compute_uv=False)


@dataclass(frozen=True)
class Identification:
    """What the data determine.

    Attributes:
        rank: the number of parameter combinations determined (the identification Jacobian's rank).
        selected: indices (rank,) of the parameters standing for them (the rest held at their start).
        unidentifiable: ``{"name", "reason"}`` per other parameter.
        condition_number: of the identifiable combinations: the largest over the smallest retained
            singular value of the column-equilibrated Jacobian (independent of the representatives).
        singular_values: of the whole column-equilibrated Jacobian, descending.
    """

    rank: int
    selected: np.ndarray
    unidentifiable: list
    condition_number: float
    singular_values: np.ndarray


def preference_tiers(em: ErrorModel) -> list[list[int]]:
    """Parameter indices in tiers of preference as representatives: the base, the tool, the zero
    offsets, the compliances (if any), then each joint's origin from the last joint to the first."""
    ps = em.parameters
    tiers = [[i for i, p in enumerate(ps) if p.group == "base"], [i for i, p in enumerate(ps) if p.group == "tool"],
             [i for i, p in enumerate(ps) if p.component == "offset"],
             [i for i, p in enumerate(ps) if p.component == "compliance"]]
    for k in reversed(range(len(em.joints))):
        tiers.append([i for i, p in enumerate(ps) if p.joint_index == k and p.component not in ("offset", "compliance")])
    return [t for t in tiers if t]


def identify(em: ErrorModel, J: np.ndarray, measure: str) -> Identification:
    """Rank, representatives and the reasons for the rest, from the stacked Jacobian J (m, p).

    The rank is the number of singular values of the column-equilibrated J above
    :data:`RANK_TOLERANCE` of the largest. The representatives are picked tier by tier
    (:func:`preference_tiers`) by QR with column pivoting restricted to the tier: the column
    farthest from the span of those already chosen first, while it is off that span.
    """
    norms = np.linalg.norm(J, axis=0)
    scale = norms.max() if norms.size and norms.max() > 0 else 1.0
    live = norms > RANK_TOLERANCE * scale
    A = np.where(live, J / np.where(live, norms, 1.0), 0.0)  # unit columns (dead ones zero)
    s = singular_values(A)
    threshold = RANK_TOLERANCE * max(s[0] if s.size else 1.0, 1.0)
    rank = int(np.sum(s > threshold))
    chosen: list[int] = []
    basis = np.zeros((A.shape[0], 0))
    for tier in preference_tiers(em):
        left = [i for i in tier if live[i]]
        while left and len(chosen) < rank:
            R = A[:, left] - basis @ (basis.T @ A[:, left])
            R -= basis @ (basis.T @ R)  # twice is enough (Kahan-Parlett)
            res = np.linalg.norm(R, axis=0)
            k = int(np.argmax(res))
            if res[k] < np.sqrt(RANK_TOLERANCE):
                break
            basis = np.column_stack([basis, R[:, k] / res[k]])
            chosen.append(left.pop(k))
    if len(chosen) != rank:  # a borderline column: fall back to testing each one's rank
        chosen = []
        for tier in preference_tiers(em):
            for i in tier:
                if live[i] and len(chosen) < rank and _rank(A[:, chosen + [i]], threshold) > len(chosen):
                    chosen.append(i)
    selected = np.array(sorted(chosen), dtype=np.intp)
    others = [i for i in range(J.shape[1]) if i not in chosen]
    # every other column as a combination of the chosen ones (one least-squares solve for all)
    coefs = np.linalg.lstsq(A[:, chosen], A[:, others], rcond=None)[0] if chosen and others else None
    reasons = [{"name": em.names[i], "reason": _reason(em, live, chosen, i, measure,
                                                       None if coefs is None else coefs[:, k])}
               for k, i in enumerate(others)]
    cond = float(s[0] / s[rank - 1]) if rank else float("inf")
    return Identification(rank, selected, reasons, cond, s)


def _rank(A: np.ndarray, threshold: float) -> int:
    if A.shape[1] == 0:
        return 0
    return int(np.sum(singular_values(A) > threshold))


def _reason(em: ErrorModel, live, chosen, i, measure, coef) -> str:
    p = em.parameters[i]
    if not live[i] or coef is None:
        return "unobservable from positions" if measure == "position" else "does not move the measured frame"
    big = np.abs(coef) > 1e-6 * max(np.abs(coef).max(), 1e-300)
    groups = {em.parameters[chosen[k]].group for k in np.flatnonzero(big)}
    names = [em.parameters[chosen[k]].name for k in np.flatnonzero(big)]
    own = p.group
    nxt = (em.joints[p.joint_index + 1].name if 0 <= p.joint_index < len(em.joints) - 1 else "tool") \
        if p.joint_index >= 0 else None
    if "base" in groups and groups <= {"base", own}:
        return "absorbed by the base frame"
    if groups <= {own}:
        if f"{own}.offset" in names and len(names) == 1:
            return f"the same motion as {own}.offset"
        return f"a combination of {own}'s other parameters"
    if nxt is not None and groups <= {own, nxt} and nxt in groups:
        return "absorbed by the tool" if nxt == "tool" else f"absorbed by the next joint ({nxt})"
    if p.group == "tool" and groups <= {"tool", em.joints[-1].name if em.joints else "tool"}:
        return "absorbed by the last joint"
    return "a combination of " + ", ".join(sorted(groups)) + " parameters"
