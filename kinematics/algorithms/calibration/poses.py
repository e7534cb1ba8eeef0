"""Pose selection: where to drive the arm before measuring, so that the data determine the most.

From the nominal model, :func:`select_poses` draws a pool of random configurations within the
limits, and chooses ``n`` of them that maximise the D-optimality of the identification
Jacobian -- ``log det(J^T J)`` over the identifiable combinations, columns scaled to the pool's
(the volume of the parameters' confidence ellipsoid shrinks as it grows) -- greedily (each step
adds the candidate that raises it most, by the matrix determinant lemma), then by exchange
(swap a chosen configuration for a candidate while that raises it). The answer carries that
measure for the choice and, for comparison, for ``n`` random configurations of the pool.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import CalibrationError
from ...model.robot import RobotModel
from .errors_model import ErrorModel
from .identification import identify


@dataclass(frozen=True)
class PoseChoice:
    """``q`` (n, dof) and the measure of the choice: ``log_det`` (of the scaled ``J^T J``),
    ``condition_number`` (column-equilibrated), ``identifiable`` (combinations determined);
    ``random_log_det`` and ``random_condition_number`` of n random configurations of the pool."""

    q: np.ndarray
    log_det: float
    condition_number: float
    identifiable: int
    random_log_det: float
    random_condition_number: float
    criterion: str = "D-optimality"


def select_poses(model: RobotModel, link: str, n: int, measure: str = "position", random_seed: int = 0,
                 point=(0.05, 0.05, 0.05), candidates: int | None = None, parameters: str = "full") -> PoseChoice:
    """``n`` configurations within the limits that best determine the calibration of ``link``.

    ``point``: where the marker is expected on the link (a point off the last joint's axis, so
    that its motion is seen); ``candidates``: the pool size (default ``max(20 n, 400)``).
    """
    if measure not in ("position", "pose"):
        raise CalibrationError(f"unknown measure {measure!r}; expected 'position' or 'pose'", field="measure")
    if not isinstance(n, (int, np.integer)) or n < 1:
        raise CalibrationError(f"n must be a positive number of configurations, got {n!r}", field="n")
    em = ErrorModel(model, link, measure, parameters, "estimate", "estimate", point=np.asarray(point, dtype=float))
    rng = np.random.default_rng(random_seed)
    K = int(candidates or max(20 * n, 400))
    if K < n:
        raise CalibrationError(f"the pool of {K} candidates is smaller than n = {n}", field="candidates")
    pool = model.sample_configurations(K, rng)
    _, cols = em.jacobian(pool, em.x0)
    d = 3 if measure == "position" else 6
    J = cols[:, :d, :]  # (K, d, p)
    ident = identify(em, J.reshape(-1, J.shape[-1]), measure)
    if ident.rank == 0:
        raise CalibrationError(f"no parameter of the chain to {link!r} can be identified", field="link")
    sel = ident.selected
    scale = np.linalg.norm(J[:, :, sel].reshape(-1, len(sel)), axis=0) / np.sqrt(K)
    G = J[:, :, sel] / scale  # (K, d, r), each column of unit mean square over the pool
    r = len(sel)
    ridge = 1e-9 * np.eye(r)
    chosen: list[int] = []
    A = ridge.copy()
    for _ in range(n):  # greedy: det(A + G_k^T G_k) = det(A) det(I + G_k A^-1 G_k^T)
        Ainv = np.linalg.inv(A)
        M = np.eye(d) + G @ Ainv @ np.swapaxes(G, 1, 2)
        gain = np.linalg.slogdet(M)[1]
        gain[chosen] = -np.inf
        k = int(np.argmax(gain))
        chosen.append(k)
        A = A + G[k].T @ G[k]
    for _ in range(3):  # exchange passes
        improved = False
        for slot in range(n):
            rest = A - G[chosen[slot]].T @ G[chosen[slot]]
            Rinv = np.linalg.inv(rest + ridge)
            gain = np.linalg.slogdet(np.eye(d) + G @ Rinv @ np.swapaxes(G, 1, 2))[1]
            gain[chosen] = -np.inf
            k = int(np.argmax(gain))
            current = np.linalg.slogdet(np.eye(d) + G[chosen[slot]] @ Rinv @ G[chosen[slot]].T)[1]
            if gain[k] > current + 1e-9:
                chosen[slot] = k
                A = rest + G[k].T @ G[k]
                improved = True
        if not improved:
            break
    rnd = rng.choice(K, size=n, replace=False)
    return PoseChoice(pool[chosen], *_measure(G[chosen]), ident.rank if n * d >= ident.rank else n * d,
                      *_measure(G[rnd]))


def _measure(G: np.ndarray) -> tuple[float, float]:
    Js = G.reshape(-1, G.shape[-1])
    sign, logdet = np.linalg.slogdet(Js.T @ Js)
    norms = np.linalg.norm(Js, axis=0)
    s = np.linalg.svd(Js / np.where(norms > 0, norms, 1.0), compute_uv=False)
    return (float(logdet) if sign > 0 else float("-inf")), (float(s[0] / s[-1]) if s[-1] > 0 else float("inf"))
