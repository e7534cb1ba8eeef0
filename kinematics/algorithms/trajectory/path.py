"""Geometric paths ``q(s)`` through joint waypoints, as piecewise polynomials in the path parameter.

A :class:`PiecewisePath` holds breakpoints ``s_0 < ... < s_P`` and, per piece, the coefficients of
a polynomial in the local coordinate ``t = s - s_p`` for every joint; it evaluates ``q``, ``q'``,
``q''`` and ``q'''`` (derivatives with respect to ``s``) exactly, and bounds them over a piece's
sub-interval exactly (:func:`poly_range`), which is what makes the time parameterisation safe
between its grid points.

Two paths (the wire contract's ``interpolation``):

- :func:`spline_path`: the C2 cubic spline through the waypoints at ``s = 0, 1/(M-1), ..., 1``
  with not-a-knot ends (``scipy.interpolate.CubicSpline(np.linspace(0, 1, M), waypoints)``; two
  waypoints give the straight line, three the parabola, as SciPy has it), solved here with the
  tridiagonal system of the knots' second derivatives.
- :func:`linear_path`: straight segments, parameterised by joint-space arc length, joined at each
  inner waypoint ``C`` by a C2 quartic blend over ``sigma`` in ``[-d, d]`` around the corner:
  ``q = C + a sigma + (b - a) d h(sigma / d)`` with ``a``, ``b`` the unit directions in and out and
  ``h(x) = x / 2 + 3/16 + 3/8 x^2 - 1/16 x^4`` (``h`` matches ``max(x, 0)`` to second order at
  ``x = -1`` and ``x = 1``). ``d = min(blend, half of each neighbouring segment)``; every blend
  point is within ``d`` of its corner (``|q - C| <= 2 e(x) d <= d``), so within ``blend``, and in
  the convex hull of the corner and its neighbours. ``blend = 0`` stops at each corner: the path
  is split there into pieces (:attr:`PiecewisePath.stops`) each timed from rest to rest.

>>> import numpy as np
>>> path = spline_path(np.array([[0.0, 0.0], [1.0, 2.0], [0.0, 4.0]]))
>>> path.q(np.array([0.25])).round(12)
array([[0.75, 1.  ]])
"""

from __future__ import annotations

from dataclasses import dataclass
from math import comb

import numpy as np

#: the quartic blend ``h(x)``'s coefficients (x^0 .. x^4): ``x / 2 + 3/16 + 3/8 x^2 - 1/16 x^4``
BLEND_H = np.array([3 / 16, 1 / 2, 3 / 8, 0.0, -1 / 16])


@dataclass(frozen=True, eq=False)
class PiecewisePath:
    """``q(s)`` on ``[breaks[0], breaks[-1]]``: ``coeffs`` (P, D + 1, dof), piece p's polynomial
    ``sum_k coeffs[p, k] (s - breaks[p])^k``; ``stops``: the breakpoints where the path turns a
    corner (the trajectory is at rest there)."""

    breaks: np.ndarray  # (P + 1,)
    coeffs: np.ndarray  # (P, D + 1, dof)
    stops: tuple[float, ...] = ()

    @property
    def dof(self) -> int:
        return self.coeffs.shape[2]

    @property
    def length(self) -> float:
        return float(self.breaks[-1] - self.breaks[0])

    def piece(self, s: np.ndarray) -> np.ndarray:
        """The piece index of each ``s`` (the last piece holds the end)."""
        return np.clip(np.searchsorted(self.breaks, s, side="right") - 1, 0, len(self.coeffs) - 1)

    def derivative(self, s: np.ndarray, order: int) -> np.ndarray:
        """(K, dof): the ``order``-th derivative of q with respect to s at ``s`` (K,)."""
        s = np.asarray(s, dtype=float)
        p = self.piece(s)
        return poly_eval(poly_derivative(self.coeffs, order)[p], (s - self.breaks[p])[:, None])

    def q(self, s: np.ndarray) -> np.ndarray:
        return self.derivative(s, 0)

    def split(self) -> list["PiecewisePath"]:
        """The path cut at its :attr:`stops`, each part a path of its own (the same ``s``)."""
        if not self.stops:
            return [self]
        cuts = [0] + [int(np.searchsorted(self.breaks, s)) for s in self.stops] + [len(self.coeffs)]
        return [PiecewisePath(self.breaks[a:b + 1], self.coeffs[a:b]) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]


def poly_eval(c: np.ndarray, t: np.ndarray, order: int = 0) -> np.ndarray:
    """``d^order/dt^order sum_k c[..., k, :] t^k`` (Horner); ``c`` (..., D + 1, dof), ``t`` broadcasting to (..., dof)."""
    c = poly_derivative(c, order)
    out = np.zeros(np.broadcast_shapes(c[..., 0, :].shape, np.shape(t)))
    for k in range(c.shape[-2] - 1, -1, -1):
        out = out * t + c[..., k, :]
    return out


def poly_derivative(c: np.ndarray, order: int = 1) -> np.ndarray:
    """The coefficients (..., D + 1 - order, dof) of the ``order``-th derivative (at least a constant)."""
    for _ in range(order):
        D = c.shape[-2] - 1
        if D == 0:
            return np.zeros_like(c)
        c = c[..., 1:, :] * np.arange(1, D + 1)[:, None]
    return c


def poly_range(c: np.ndarray, t0: np.ndarray, t1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact ``(min, max)`` over ``t`` in ``[t0, t1]`` of polynomials of degree at most 3:
    ``c`` (..., D + 1, dof) with D <= 3, ``t0``, ``t1`` broadcasting to (..., 1). The candidates are
    the ends and the real roots of the derivative inside the interval."""
    c = np.concatenate([c, np.zeros(c.shape[:-2] + (max(0, 4 - c.shape[-2]),) + c.shape[-1:])], axis=-2)
    if c.shape[-2] > 4:
        raise ValueError("poly_range handles degree 3 at most")
    lo, hi = poly_eval(c, t0), poly_eval(c, t1)
    vmin, vmax = np.minimum(lo, hi), np.maximum(lo, hi)
    a, b, cc = 3 * c[..., 3, :], 2 * c[..., 2, :], c[..., 1, :]  # derivative a t^2 + b t + cc
    disc = b * b - 4 * a * cc
    with np.errstate(divide="ignore", invalid="ignore"):
        root = np.sqrt(np.where(disc >= 0, disc, 0.0))
        qq = -0.5 * (b + np.where(b >= 0, root, -root))
        cands = [qq / a, cc / qq, np.where(a == 0, -cc / b, np.nan)]
    for r in cands:
        ok = (disc >= 0) & np.isfinite(r) & (r > t0) & (r < t1)
        v = poly_eval(c, np.where(ok, r, t0))
        vmin = np.where(ok, np.minimum(vmin, v), vmin)
        vmax = np.where(ok, np.maximum(vmax, v), vmax)
    return vmin, vmax


def spline_second_derivatives(y: np.ndarray, h: float) -> np.ndarray:
    """(M, dof) second derivatives at the knots of the not-a-knot cubic spline through ``y`` (M >= 4,
    equal spacing ``h``): the interior equations ``M_{i-1} + 4 M_i + M_{i+1} = 6 (y_{i+1} - 2 y_i +
    y_{i-1}) / h^2`` with ``M_0 = 2 M_1 - M_2`` and ``M_{n} = 2 M_{n-1} - M_{n-2}`` (the third
    derivative continuous at the second and last-but-one knots), solved by the Thomas algorithm."""
    n = len(y)
    r = 6.0 * (y[2:] - 2 * y[1:-1] + y[:-2]) / h**2  # (n - 2, dof), unknowns M_1 .. M_{n-2}
    m = n - 2
    lower = np.ones(m)
    diag = np.full(m, 4.0)
    upper = np.ones(m)
    diag[0], upper[0] = 6.0, 0.0  # M_0 substituted
    diag[-1], lower[-1] = 6.0, 0.0  # M_{n-1} substituted
    cp = np.zeros(m)
    dp = np.zeros_like(r)
    cp[0], dp[0] = upper[0] / diag[0], r[0] / diag[0]
    for i in range(1, m):
        den = diag[i] - lower[i] * cp[i - 1]
        cp[i] = upper[i] / den
        dp[i] = (r[i] - lower[i] * dp[i - 1]) / den
    x = np.zeros_like(r)
    x[-1] = dp[-1]
    for i in range(m - 2, -1, -1):
        x[i] = dp[i] - cp[i] * x[i + 1]
    return np.vstack([2 * x[0] - x[1], x, 2 * x[-1] - x[-2]])


def spline_path(waypoints: np.ndarray) -> PiecewisePath:
    """The not-a-knot cubic spline through ``waypoints`` (M, dof) at ``s = linspace(0, 1, M)``."""
    y = np.asarray(waypoints, dtype=float)
    M = len(y)
    h = 1.0 / (M - 1)
    if M == 2:
        Mk = np.zeros_like(y)
    elif M == 3:
        Mk = np.repeat(((y[2] - 2 * y[1] + y[0]) / h**2)[None], 3, axis=0)
    else:
        Mk = spline_second_derivatives(y, h)
    slope = (y[1:] - y[:-1]) / h - h * (2 * Mk[:-1] + Mk[1:]) / 6
    coeffs = np.stack([y[:-1], slope, Mk[:-1] / 2, (Mk[1:] - Mk[:-1]) / (6 * h)], axis=1)
    return PiecewisePath(np.linspace(0.0, 1.0, M), coeffs)


def linear_path(waypoints: np.ndarray, blend: float = 0.0) -> PiecewisePath:
    """Straight segments between ``waypoints`` (M, dof), parameterised by joint-space arc length,
    joined by C2 quartic blends within ``blend`` of each inner waypoint (0: stop there).
    Repeated waypoints are dropped (a segment of length 0 has no direction)."""
    y = np.asarray(waypoints, dtype=float)
    keep = np.r_[True, np.linalg.norm(np.diff(y, axis=0), axis=1) > 0]
    y = y[keep]
    dof = y.shape[1]
    if len(y) == 1:  # no motion at all
        return PiecewisePath(np.array([0.0, 0.0]), np.zeros((1, 5, dof)) + np.r_[1.0, 0, 0, 0, 0][:, None] * y[0])
    seg = np.diff(y, axis=0)
    L = np.linalg.norm(seg, axis=1)
    u = seg / L[:, None]
    S = np.r_[0.0, np.cumsum(L)]  # arc length at the waypoints
    d = np.zeros(len(y))
    if blend > 0:
        d[1:-1] = np.minimum(blend, 0.5 * np.minimum(L[:-1], L[1:]))
    breaks, coeffs, stops = [0.0], [], []
    for i in range(len(L)):
        start, end = S[i] + d[i], S[i + 1] - d[i + 1]
        if end > start:  # the straight part
            c = np.zeros((5, dof))
            c[0], c[1] = y[i] + u[i] * d[i], u[i]
            coeffs.append(c)
            breaks.append(end)
        if i + 1 < len(L):
            if d[i + 1] > 0:  # the blend around waypoint i + 1, sigma = s - S[i + 1] in [-d, d]
                coeffs.append(blend_coefficients(y[i + 1], u[i], u[i + 1], d[i + 1]))
                breaks.append(S[i + 1] + d[i + 1])
            else:
                stops.append(S[i + 1])
    return PiecewisePath(np.array(breaks), np.array(coeffs), tuple(stops))


def blend_coefficients(C: np.ndarray, a: np.ndarray, b: np.ndarray, d: float) -> np.ndarray:
    """(5, dof) coefficients in ``t = sigma + d`` of ``C + a sigma + (b - a) d h(sigma / d)``."""
    # in x = sigma / d: C + a d x + (b - a) d h(x); then x = t / d - 1
    cx = np.outer(BLEND_H, b - a) * d
    cx[0] += C
    cx[1] += a * d
    # substitute x = t / d - 1: expand each power with the binomial theorem
    out = np.zeros_like(cx)
    for k in range(5):
        for j in range(k + 1):  # (t/d - 1)^k = sum_j C(k, j) (t/d)^j (-1)^(k - j)
            out[j] += cx[k] * comb(k, j) * (-1) ** (k - j) / d**j
    return out
