"""Time-optimal parameterisation of a path under velocity and acceleration limits (and a tool's
linear speed), safe at every instant, by reachability analysis on the path parameter.

The unknowns are ``x = sdot^2`` at grid points ``s_0 < ... < s_N`` (the path's breakpoints among
them) and ``u = sddot``, constant on each interval, so that ``x`` is linear in ``s`` there:
``x(s) = x_i + 2 u_i (s - s_i)`` (the profile TOPP-RA computes). On interval ``i`` a joint's
acceleration is ``q' u + q'' x(s) = u A(s) + x_i B(s)`` with ``A(s) = q'(s) + 2 (s - s_i) q''(s)``
and ``B = q''``: linear in ``(x_i, u_i)`` with coefficients that are polynomials of the path.
Bounding ``A`` and ``B`` exactly over the interval (:func:`~.path.poly_range`) turns "the limit
holds at every ``s`` of the interval" into four linear rows per joint that are sufficient
(``max(u A_lo, u A_hi) + x_i B_hi <= a`` and the like below), so every instant is covered, not
only the grid points. The velocity limit ``|q'(s)| sdot <= v`` holds on the interval when it
holds at both ends with ``max |q'|`` over the interval (``x`` is linear, so its largest value is
at an end). The tool speed ``|J_v(q(s)) q'(s)| sdot <= v_tool`` is held the same way with a proven
bound of the tool rate ``w(s) = |dp/ds|`` over the interval (:meth:`ToolRate.bound`): the tool
point's derivatives are bounded from the interval's exact ranges of ``q'``, ``q''``, ``q'''``
(``|d^2p/ds^2| <= L = C (sum_i c_i max|q_i''| + (sum_i c_i max|q_i'|)^2)`` and a like ``M`` for
``|d^3p/ds^3|``; ``C`` the chain's reach, ``c_i`` how much joint i drives the chain), so ``w`` is at
most the largest of ``k + 1`` equally spaced samples plus ``min(L d / 2, M d^2 / 8)`` (``d = h / k``
the spacing; the first as ``w`` is ``L``-Lipschitz, the second as ``dp/ds`` departs from the chord
between two samples by at most ``M d^2 / 8`` and the chord's norm is at most its larger end's);
``k`` grows on the intervals where the tool limits the speed until that term is a small fraction
of the samples.

Then, as TOPP-RA: a backward pass computes the controllable sets ``[0, X_i]`` (the largest
``x_i`` from which the end is reached at rest; each step a two-variable linear programme solved
exactly over its vertices), a forward pass takes the largest ``u_i`` that keeps ``x_{i+1}``
controllable. The time of interval ``i`` is ``2 (s_{i+1} - s_i) / (sqrt(x_i) + sqrt(x_{i+1}))``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from ...engine.cancel import check
from .passes import backward_steps, forward_steps
from .path import PiecewisePath, poly_derivative, poly_eval, poly_range

#: The limits are scaled by ``1 - LIMIT_MARGIN`` inside the planner, so that rounding never
#: takes an answer over them.
LIMIT_MARGIN = 1e-6
#: Largest ``sdot^2`` where nothing limits it (a piece of the path that does not move).
X_CAP = 1e12
#: Grid steps between two checks of the time budget.
CHECK_EVERY = 512


@dataclass(frozen=True, eq=False)
class ToolRate:
    """The tool's linear speed per unit path speed: ``rate(Q (K, dof), Qp (K, dof)) -> (K,)``,
    ``w = |J_v(q) q'|``, and its limit ``max`` (m/s).

    ``reach`` (``C``) and ``weights`` (``c``, (dof,)) bound the derivatives of the tool point along any
    path: ``|d^2p/ds^2| <= C (b + a^2)`` and ``|d^3p/ds^3| <= C (e + 3 a b + a^3)`` with ``a``, ``b``,
    ``e`` the sums ``sum_i c_i |q_i'|``, ``sum_i c_i |q_i''|``, ``sum_i c_i |q_i'''|``. For a serial
    chain, ``C = max(1, R)`` with ``R`` a bound of the distance from any joint axis of the chain to the
    tool point (every partial derivative of the tool point of order 1 to 3 in the joint values is at
    most ``R`` for revolute joints, 1 or 0 with a prismatic one), ``c_i`` the sum of ``|multiplier|`` of the chain's joints
    driven by joint i (1 for a joint of the chain, 0 off it). ``q'`` is continuous along a path
    timed from rest to rest (a part between stops), so ``w`` is continuous and the bound holds
    across the path's breakpoints. An interval's bound samples ``w`` at
    ``subsamples + 1`` points, more (up to ``most_subsamples``) where the :meth:`margin` exceeds
    ``tolerance`` of the samples' largest value and the tool limits the speed."""

    rate: Callable[[np.ndarray, np.ndarray], np.ndarray]
    max: float
    reach: float
    weights: np.ndarray
    subsamples: int = 4
    most_subsamples: int = 1024
    tolerance: float = 1e-3

    def margin(self, spacing: np.ndarray, ranges) -> np.ndarray:
        """(K,) how far ``w`` may rise above the larger of two samples ``spacing`` (K,) apart, where
        ``ranges`` = ``(max|q'|, max|q''|, max|q'''|)`` (each (K, dof)): ``min(L d / 2, M d^2 / 8)``."""
        a, b, e = (np.asarray(r) @ self.weights for r in ranges)
        return self.reach * np.minimum((b + a * a) * spacing / 2, (e + 3 * a * b + a**3) * spacing**2 / 8)

    def sampled(self, path: PiecewisePath, s0: np.ndarray, s1: np.ndarray, k: int) -> np.ndarray:
        """(K,) the largest ``w`` of ``k + 1`` equally spaced samples of each ``[s0, s1]`` (K,)."""
        ss = (s0[:, None] + (s1 - s0)[:, None] * np.linspace(0.0, 1.0, k + 1)).ravel()
        return self.rate(path.q(ss), path.derivative(ss, 1)).reshape(len(s0), k + 1).max(axis=1)

    def bound(self, path: PiecewisePath, s0: np.ndarray, s1: np.ndarray, ranges, k: int) -> np.ndarray:
        """(K,) a bound of ``w`` at every ``s`` of each ``[s0, s1]`` (K,), ``ranges`` as :meth:`margin`'s
        over it: the largest of ``k + 1`` equally spaced samples plus the margin of their spacing."""
        return self.sampled(path, s0, s1, k) + self.margin((s1 - s0) / k, ranges)


@dataclass(frozen=True, eq=False)
class Profile:
    """A path-parameter profile: grid ``s`` (N + 1), ``x = sdot^2`` (N + 1), ``u = sddot`` (N) on each
    interval, ``t`` (N + 1) the times of the grid points."""

    s: np.ndarray
    x: np.ndarray
    u: np.ndarray
    t: np.ndarray

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    def at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(s, sdot, sddot)`` at times ``t`` (clipped to ``[0, duration]``)."""
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.duration)
        i = np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, len(self.u) - 1)
        tau = t - self.t[i]
        sd0 = np.sqrt(self.x[i])
        s = np.minimum(self.s[i] + sd0 * tau + 0.5 * self.u[i] * tau**2, self.s[i + 1])
        return s, np.maximum(sd0 + self.u[i] * tau, 0.0), self.u[i]


def grid(path: PiecewisePath, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(s (N + 1,), piece (N,))``: about ``n`` intervals spread over the path by length, each piece
    of the path cut into at least one; ``piece[i]`` is the piece interval ``i`` lies in."""
    lengths = np.diff(path.breaks)
    total = lengths.sum()
    counts = np.maximum(1, np.ceil(n * lengths / total).astype(int)) if total > 0 else np.ones(len(lengths), int)
    s = [np.linspace(path.breaks[p], path.breaks[p + 1], c + 1)[:-1] for p, c in enumerate(counts)]
    return np.r_[np.concatenate(s), path.breaks[-1]], np.repeat(np.arange(len(lengths)), counts)


def interval_rows(path: PiecewisePath, s: np.ndarray, piece: np.ndarray, a: np.ndarray):
    """The linear rows ``cu u + cx x_i <= r`` (each (N, 4 dof)) that keep every joint's acceleration
    within ``a`` over each whole interval, and ``(max |q'|, max |q''|, max |q'''|)`` (each (N, dof))
    over each interval."""
    c = path.coeffs[piece]  # (N, D + 1, dof)
    t0 = (s[:-1] - path.breaks[piece])[:, None]
    t1 = (s[1:] - path.breaks[piece])[:, None]
    c1 = poly_derivative(c, 1)
    c2 = poly_derivative(c, 2)
    lo1, hi1 = poly_range(c1, t0, t1)
    # A(t) = q'(t) + 2 (t - t0) q''(t), in the piece's local coordinate t
    shifted = np.zeros(c1.shape[:1] + (c2.shape[1] + 1,) + c1.shape[2:])
    shifted[:, 1:] += 2 * c2
    shifted[:, :-1] -= 2 * t0[:, :, None] * c2
    width = max(c1.shape[1], shifted.shape[1])
    A = np.zeros((len(c), width, c.shape[2]))
    A[:, :c1.shape[1]] += c1
    A[:, :shifted.shape[1]] += shifted
    Alo, Ahi = poly_range(A, t0, t1)
    Blo, Bhi = poly_range(c2, t0, t1)
    cu = np.concatenate([Ahi, Alo, -Alo, -Ahi], axis=1)
    cx = np.concatenate([Bhi, Bhi, -Blo, -Blo], axis=1)
    r = np.tile(a, 4)[None].repeat(len(c), axis=0)
    lo3, hi3 = poly_range(poly_derivative(c, 3), t0, t1)
    ranges = tuple(np.maximum(np.abs(lo), np.abs(hi)) for lo, hi in ((lo1, hi1), (Blo, Bhi), (lo3, hi3)))
    return cu, cx, r, ranges


def velocity_bound(qp_max: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(N,) the largest ``x`` on each interval that keeps every ``|q'| sdot`` within ``v``."""
    with np.errstate(divide="ignore", over="ignore"):
        return np.minimum(np.min(np.where(qp_max > 0, (v / qp_max) ** 2, np.inf), axis=1), X_CAP)


def speed_cap(w: np.ndarray, vmax: float) -> np.ndarray:
    """The largest ``x = sdot^2`` that keeps ``w sdot`` within ``vmax`` (``X_CAP`` where ``w`` is 0)."""
    with np.errstate(divide="ignore", over="ignore"):
        return np.minimum(np.where(w > 0, (vmax / np.maximum(w, 0.0)) ** 2, np.inf), X_CAP)


def tool_bound(path: PiecewisePath, s: np.ndarray, tool: ToolRate, ranges, xint: np.ndarray) -> np.ndarray:
    """(N,) the largest ``x`` on each interval that keeps the tool's speed within ``tool.max`` at every
    ``s`` of it (:meth:`ToolRate.bound` with the interval's ``ranges`` of ``|q'|``, ``|q''|``,
    ``|q'''|``). Where that cap is below ``xint`` (the tool limits the speed there) and the margin is
    over ``tool.tolerance`` of the samples, the interval is sampled 4 times more densely, up to
    ``tool.most_subsamples``."""
    k = tool.subsamples
    h = np.diff(s)
    margin = tool.margin(h / k, ranges)
    bound = tool.sampled(path, s[:-1], s[1:], k) + margin
    todo = np.flatnonzero((margin > tool.tolerance * bound) & (speed_cap(bound, tool.max) < xint))
    while todo.size and 4 * k <= tool.most_subsamples:
        check()
        k *= 4
        sub = tuple(r[todo] for r in ranges)
        bound[todo] = tool.bound(path, s[todo], s[todo + 1], sub, k)
        todo = todo[tool.margin(h[todo] / k, sub) > tool.tolerance * bound[todo]]
    return speed_cap(bound, tool.max)


def backward(cu, cx, r, xmax, ds) -> np.ndarray:
    """(N + 1,) the largest controllable ``x_i``: ``X_N = 0``; ``X_i`` the largest ``x`` in ``[0, xmax_i]``
    with a ``u`` that meets interval i's rows and reaches ``x + 2 ds_i u`` in ``[0, X_{i+1}]``
    (each step a two-variable linear programme, solved over its vertices)."""
    N = len(ds)
    X = np.zeros(N + 1)
    for stop in range(N, 0, -CHECK_EVERY):
        check()
        backward_steps(cu, cx, r, xmax, ds, X, stop, max(0, stop - CHECK_EVERY))
    return X


def forward(cu, cx, r, X, ds) -> tuple[np.ndarray, np.ndarray]:
    """``(x (N + 1), u (N))``: from rest, the largest ``u_i`` that meets interval i's rows and keeps
    ``x_{i+1}`` in ``[0, X_{i+1}]``."""
    N = len(ds)
    x = np.zeros(N + 1)
    u = np.zeros(N)
    for start in range(0, N, CHECK_EVERY):
        check()
        forward_steps(cu, cx, r, X, ds, x, u, start, min(N, start + CHECK_EVERY))
    return x, u


def times(s: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(N + 1,) the time at each grid point of a profile linear in ``x`` on each interval."""
    root = np.sqrt(np.maximum(x, 0.0))
    den = root[:-1] + root[1:]
    with np.errstate(divide="ignore", invalid="ignore"):
        dt = np.where(den > 0, 2 * np.diff(s) / den, 0.0)
    return np.r_[0.0, np.cumsum(dt)]


def topp(path: PiecewisePath, velocity: np.ndarray, acceleration: np.ndarray, n: int = 2000,
         tool: ToolRate | None = None) -> Profile:
    """The time-optimal profile of ``path`` (one piece: from rest to rest) on about ``n`` grid
    intervals under per-joint ``velocity`` and ``acceleration`` limits (and ``tool``'s speed),
    every limit held at every instant."""
    scale = 1.0 - LIMIT_MARGIN
    s, piece = grid(path, n)
    ds = np.diff(s)
    cu, cx, r, ranges = interval_rows(path, s, piece, np.asarray(acceleration, float) * scale)
    xint = velocity_bound(ranges[0], np.asarray(velocity, float) * scale)
    if tool is not None:
        xint = np.minimum(xint, tool_bound(path, s, replace(tool, max=tool.max * scale), ranges, xint))
    xmax = np.minimum(np.r_[xint, xint[-1]], np.r_[xint[0], xint])  # both neighbouring intervals
    X = backward(cu, cx, r, xmax, ds)
    x, u = forward(cu, cx, r, X, ds)
    return Profile(s, x, u, times(s, x))


def joint_motion(path: PiecewisePath, s, sd, sdd, sddd=None):
    """``(q, qd, qdd[, qddd])`` (K, dof) along ``path`` for path-parameter values and their time derivatives."""
    q1 = path.derivative(s, 1)
    q2 = path.derivative(s, 2)
    sd, sdd = np.asarray(sd)[:, None], np.asarray(sdd)[:, None]
    out = [path.q(s), q1 * sd, q2 * sd**2 + q1 * sdd]
    if sddd is not None:
        out.append(path.derivative(s, 3) * sd**3 + 3 * q2 * sd * sdd + q1 * np.asarray(sddd)[:, None])
    return tuple(out)


__all__ = ["LIMIT_MARGIN", "Profile", "ToolRate", "topp", "joint_motion", "grid", "poly_eval"]
