"""Pose selection: where to drive the arm before measuring, so that the data determine the most.

From the nominal model, :func:`select_poses` draws a pool of random configurations within the
limits, and chooses ``n`` of them that maximise the D-optimality of the identification
Jacobian -- ``log det(J^T J)`` over the identifiable combinations, columns scaled to the pool's
(the volume of the parameters' confidence ellipsoid shrinks as it grows) -- greedily (each step
adds the candidate that raises it most, by the matrix determinant lemma), then by exchange
(swap a chosen configuration for a candidate while that raises it; two passes). The answer carries that
measure for the choice and, for comparison, for ``n`` random configurations of the pool.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...engine import cancel
from ...errors import CalibrationError
from ...model.robot import RobotModel
from .errors_model import ErrorModel
from .identification import identify, singular_values


#: the largest n; the exchange passes after the greedy choice
MAX_POSES, EXCHANGE_PASSES = 1000, 2


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
    that its motion is seen); ``candidates``: the pool size (default ``10 n``, at least 300, at most 3000).
    """
    if measure not in ("position", "pose"):
        raise CalibrationError(f"unknown measure {measure!r}; expected 'position' or 'pose'", field="measure")
    if not isinstance(n, (int, np.integer)) or n < 1:
        raise CalibrationError(f"n must be a positive number of configurations, got {n!r}", field="n")
    em = ErrorModel(model, link, measure, parameters, "estimate", "estimate", point=np.asarray(point, dtype=float))
    rng = np.random.default_rng(random_seed)
    if n > MAX_POSES:
        raise CalibrationError(f"n = {n}: choose at most {MAX_POSES} configurations", field="n")
    K = int(candidates or min(max(10 * n, 300), 3000))
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
    chosen = _d_optimal(G, n)
    rnd = rng.choice(K, size=n, replace=False)
    return PoseChoice(pool[chosen], *_measure(G[chosen]), ident.rank if n * d >= ident.rank else n * d,
                      *_measure(G[rnd]))


class _Information:
    """``A = ridge I + sum G_k^T G_k`` over a chosen set, with ``A^-1``, ``H = G A^-1`` and
    ``P = G A^-1 G^T`` for every candidate kept current by rank-d (Woodbury) updates and rebuilt
    every :data:`REFRESH` updates so that rounding does not pile up."""

    REFRESH = 16

    def __init__(self, G: np.ndarray, ridge: float = 1e-6):
        self.G = G
        self.A = ridge * np.eye(G.shape[2])
        self.updates = 0
        self._rebuild()

    def _rebuild(self):
        self.Ainv = np.linalg.inv(self.A)
        self.H = self.G @ self.Ainv
        self.P = self.H @ np.swapaxes(self.G, 1, 2)

    def gains(self) -> np.ndarray:
        """``log det(A + G_k^T G_k) - log det(A)`` for every candidate k (determinant lemma)."""
        return np.linalg.slogdet(np.eye(self.G.shape[1]) + self.P)[1]

    def update(self, k: int, sign: float = 1.0) -> None:
        """``A <- A + sign G_k^T G_k``."""
        Gk = self.G[k]
        self.A = self.A + sign * Gk.T @ Gk
        self.updates += 1
        if self.updates % self.REFRESH == 0:
            self._rebuild()
            return
        Hk = self.H[k].copy()
        Sinv = np.linalg.inv(np.eye(Gk.shape[0]) + sign * Hk @ Gk.T)
        CS = (self.H @ Gk.T) @ Sinv  # (K, d, d)
        self.P = self.P - sign * CS @ np.swapaxes(self.H @ Gk.T, 1, 2)
        self.H = self.H - sign * CS @ Hk
        self.Ainv = self.Ainv - sign * Hk.T @ Sinv @ Hk


def _d_optimal(G: np.ndarray, n: int) -> list[int]:
    """Indices of n rows of G (K, d, r) of large ``log det sum G_k^T G_k``: greedy, then exchange."""
    info = _Information(G)
    chosen: list[int] = []
    for _ in range(n):
        cancel.check()  # a cancelled or timed-out request stops here (kinematics.engine.cancel)
        gain = info.gains()
        gain[chosen] = -np.inf
        k = int(np.argmax(gain))
        chosen.append(k)
        info.update(k)
    for _ in range(EXCHANGE_PASSES):
        improved = False
        for slot in range(n):
            cancel.check()
            info.update(chosen[slot], -1.0)  # the information without this configuration
            gain = info.gains()
            current = gain[chosen[slot]]
            gain[chosen] = -np.inf
            k = int(np.argmax(gain))
            if gain[k] > current + 1e-9:
                chosen[slot] = k
                improved = True
            info.update(chosen[slot])
        if not improved:
            break
    return chosen


def _measure(G: np.ndarray) -> tuple[float, float]:
    Js = G.reshape(-1, G.shape[-1])
    sign, logdet = np.linalg.slogdet(Js.T @ Js)
    norms = np.linalg.norm(Js, axis=0)
    s = singular_values(Js / np.where(norms > 0, norms, 1.0))
    return (float(logdet) if sign > 0 else float("-inf")), (float(s[0] / s[-1]) if s[-1] > 0 else float("inf"))
