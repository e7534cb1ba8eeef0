"""Jerk-limited timing of a path: a time-optimal profile with part of the acceleration budget,
smoothed by a moving-average (FIR) filter on the path parameter, then scaled in time so that the
tightest limit is just met.

The filter (Biagiotti and Melchiorri's FIR trajectory filters) replaces ``s(t)`` by its mean
over the last ``tau`` seconds: ``s_f(t) = (S(t) - S(t - tau)) / tau`` with ``S`` the integral of
``s`` (``s`` held at its ends outside ``[0, T]``). It keeps the path (``s_f`` runs from 0 to the
end, never backwards, for ``sdot >= 0``), starts and ends at rest with path acceleration
``(sdot(t) - sdot(t - tau)) / tau`` continuous and zero at both ends, and gives the path jerk
``(sddot(t) - sddot(t - tau)) / tau`` (bounded: the profile's ``sddot`` is piecewise constant).
The joints' derivatives follow exactly from the path's: ``qdot = q' sdot``, ``qddot = q''
sdot^2 + q' sddot``, ``qdddot = q''' sdot^3 + 3 q'' sdot sddot + q' sdddot``; with ``q`` C2
(the spline, the blended path), ``qddot`` is continuous and 0 at both ends.

Time scaling by ``k`` (``t -> k t``) divides velocities by ``k``, accelerations by ``k^2`` and
jerks by ``k^3`` exactly; ``k`` is the largest of ``|qdot| / v``, ``sqrt(|qddot| / a)`` and
``cbrt(|qdddot| / j)`` where each ``|.|`` is a *proven* bound over whole time intervals covering
the motion (:func:`motion_bound`: the filtered motion is a cubic in time between its
breakpoints, the path a piecewise polynomial with exact derivative ranges, combined by interval
arithmetic, the intervals that may hold the peak split until the bound is within
:data:`BOUND_TOLERANCE` of a value the motion takes), so every limit holds at every instant, not
only at samples. The tool's speed, where limited, is bounded on the same intervals: at most
``max w(s) * max sdot`` with ``w = |J_v(q) q'|`` bounded over the interval's ``s`` range by its
values at the ends and bounds of the tool point's derivatives (:meth:`.topp.ToolRate.bound`, with
the path's exact ``q'``, ``q''``, ``q'''`` ranges), so it too holds at every instant. The acceleration
fraction given to the time-optimal profile, the filter length and a cap of the profile's velocity
are searched over a small grid (:data:`FRACTIONS`, :data:`WIDTHS`, :data:`VELOCITY_CAPS`) and
around its best (:data:`REFINE`), the shortest result kept; a candidate whose values at its
breakpoints already need a longer motion than the best is dropped before its bound is computed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...engine.cancel import check
from .path import PiecewisePath, poly_derivative, poly_range
from .topp import LIMIT_MARGIN, Profile, ToolRate, joint_motion, topp

#: fractions of the acceleration limits the time-optimal profile is given before filtering (over 1:
#: the scaling slows it down again; it may still end shorter)
FRACTIONS = (0.45, 0.6, 0.75, 0.9, 1.0, 1.15, 1.3, 1.5, 1.75)
#: filter lengths, as multiples of ``max_j 2 fraction a_j / j_j`` (the time a joint's acceleration
#: takes to swing through its range at its jerk limit)
WIDTHS = (0.25, 0.5, 0.75, 1.0, 1.5)
#: factors of the best fraction and width tried around them after the grid
REFINE = ((0.93, 1.0, 1.07), (0.8, 1.0, 1.25), (0.93, 1.07))
#: fractions of the velocity limits tried as the time-optimal profile's own velocity limit: a plateau
#: of path speed between speeding up and slowing down lets the filter be short (one at
#: :data:`CAP_WIDTH`: the filter is then as long as the acceleration takes to rise at the jerk limit)
VELOCITY_CAPS = (0.9, 0.8, 0.7, 0.6)
CAP_WIDTH = 0.5
#: the proven time scale is within this fraction of the motion's true peak ratio (see :func:`proven_scale`)
BOUND_TOLERANCE = 1e-4
#: the intervals that may hold the peak are cut into ``SPLIT`` parts, at most ``SPLIT_ROUNDS`` times
SPLIT = 4
SPLIT_ROUNDS = 12


@dataclass(frozen=True, eq=False)
class FilteredProfile:
    """``base`` filtered over ``tau`` seconds, then slowed by ``scale`` (``t = scale * t_base``)."""

    base: Profile
    tau: float
    scale: float = 1.0

    @property
    def duration(self) -> float:
        return self.scale * (self.base.duration + self.tau)

    def at(self, t: np.ndarray):
        """``(s, sdot, sddot, sdddot)`` at times ``t`` (K,)."""
        tb = np.asarray(t, dtype=float) / self.scale
        a = extended(self.base, tb)
        b = extended(self.base, tb - self.tau)
        k, tau = self.scale, self.tau
        s = np.clip((a[3] - b[3]) / tau, self.base.s[0], self.base.s[-1])
        return s, (a[0] - b[0]) / tau / k, (a[1] - b[1]) / tau / k**2, (a[2] - b[2]) / tau / k**3

    def breakpoints(self) -> np.ndarray:
        """The times where the path jerk jumps (the base grid's times, and the same after ``tau``)."""
        return self.scale * np.r_[self.base.t, self.base.t + self.tau]


def extended(p: Profile, t: np.ndarray):
    """``(s, sdot, sddot, S)`` of profile ``p`` at any time (held at rest outside ``[0, T]``), ``S`` the
    integral of ``s`` from 0."""
    T = p.duration
    sd_grid = np.sqrt(p.x)
    dt = np.diff(p.t)
    S_grid = np.r_[0.0, np.cumsum(p.s[:-1] * dt + sd_grid[:-1] * dt**2 / 2 + p.u * dt**3 / 6)]
    tc = np.clip(t, 0.0, T)
    i = np.clip(np.searchsorted(p.t, tc, side="right") - 1, 0, len(p.u) - 1)
    tau = tc - p.t[i]
    s = p.s[i] + sd_grid[i] * tau + p.u[i] * tau**2 / 2
    sd = sd_grid[i] + p.u[i] * tau
    S = S_grid[i] + p.s[i] * tau + sd_grid[i] * tau**2 / 2 + p.u[i] * tau**3 / 6
    inside = (t >= 0) & (t <= T)
    S = np.where(t < 0, p.s[0] * t, np.where(t > T, S_grid[-1] + p.s[-1] * (t - T), S))
    return s, np.where(inside, sd, 0.0), np.where(inside & (t < T), p.u[i], 0.0), S


def path_range(path: PiecewisePath, s0: np.ndarray, s1: np.ndarray, order: int):
    """``(lo, hi)`` (K, dof): the exact range of ``q^(order)(s)`` over ``s`` in ``[s0, s1]`` (K,), the union
    over the pieces of the path the interval overlaps (both sides of a breakpoint)."""
    c = poly_derivative(path.coeffs, order)
    s1 = np.maximum(s1, s0)
    first, last = path.piece(s0), path.piece(s1)
    lo = np.full((len(s0), path.dof), np.inf)
    hi = np.full((len(s0), path.dof), -np.inf)
    for offset in range(int(np.max(last - first, initial=0)) + 1):
        p = np.minimum(first + offset, len(c) - 1)
        a = np.maximum(s0, path.breaks[p]) - path.breaks[p]
        b = np.maximum(np.minimum(s1, path.breaks[p + 1]) - path.breaks[p], a)
        plo, phi = poly_range(c[p], a[:, None], b[:, None])
        inside = (first + offset <= last)[:, None]
        lo, hi = np.where(inside, np.minimum(lo, plo), lo), np.where(inside, np.maximum(hi, phi), hi)
    return lo, hi


def product(a, b):
    """The interval ``a * b`` (each a ``(lo, hi)`` pair of broadcasting arrays)."""
    p = np.stack(np.broadcast_arrays(a[0] * b[0], a[0] * b[1], a[1] * b[0], a[1] * b[1]))
    return p.min(axis=0), p.max(axis=0)


def motion_bound(path: PiecewisePath, f: FilteredProfile, ta: np.ndarray, tb: np.ndarray,
                 tool: ToolRate | None = None):
    """``(|qd|, |qdd|, |qddd|)``, each (K, dof): bounds of every joint's velocity, acceleration and jerk
    over each closed time interval ``[ta, tb]`` (K,) lying between two consecutive
    :meth:`FilteredProfile.breakpoints`, valid at every instant of it, not at samples; with ``tool``,
    a fourth (K, 1): a bound of the tool's speed there, ``max w * max sdot`` (``w`` bounded over the
    ``s`` range by :meth:`.topp.ToolRate.bound` from its two ends).

    There the path jerk is a constant ``j0``, so ``sddot`` is linear (its range: the ends), ``sdot``
    quadratic (the ends and the vertex) and ``s`` monotone (``[s_a, s_b]``). Over that ``s`` range
    :func:`path_range` gives the exact ranges of the path's first three derivatives, and interval
    arithmetic on ``qdot = q' sdot``, ``qddot = q'' sdot^2 + q' sddot`` and ``qdddot = q''' sdot^3 +
    3 q'' sdot sddot + q' j0`` encloses every value the joints take on the interval (the enclosure
    exceeds the true range by terms of the order of the interval's length)."""
    s_a, sd_a, sdd_a, _ = f.at(ta)
    s_b, sd_b, sdd_b, _ = f.at(tb)
    j0 = f.at((ta + tb) / 2)[3]
    with np.errstate(divide="ignore", invalid="ignore"):
        hv = np.where(j0 != 0, -sdd_a / j0, -1.0)  # where sddot = 0: the vertex of sdot
    vertex = np.where((hv > 0) & (hv < tb - ta), sd_a + sdd_a * hv + 0.5 * j0 * hv**2, sd_a)
    sd_lo = np.maximum(np.minimum(np.minimum(sd_a, sd_b), vertex), 0.0)[:, None]
    sd_hi = np.maximum(np.maximum(sd_a, sd_b), vertex)[:, None]
    sd, sdd = (sd_lo, sd_hi), (np.minimum(sdd_a, sdd_b)[:, None], np.maximum(sdd_a, sdd_b)[:, None])
    q1, q2, q3 = (path_range(path, np.minimum(s_a, s_b), np.maximum(s_a, s_b), order) for order in (1, 2, 3))
    sd_sdd = product(sd, sdd)
    terms = [[product(q1, sd)],
             [product(q2, (sd_lo**2, sd_hi**2)), product(q1, sdd)],
             [product(q3, (sd_lo**3, sd_hi**3)), product(q2, (3 * sd_sdd[0], 3 * sd_sdd[1])),
              product(q1, (j0[:, None], j0[:, None]))]]
    out = tuple(np.maximum(np.abs(sum(lo for lo, _ in ts)), np.abs(sum(hi for _, hi in ts))) for ts in terms)
    if tool is None:
        return out
    s_lo, s_hi = np.minimum(s_a, s_b), np.maximum(s_a, s_b)
    ranges = tuple(np.maximum(np.abs(lo), np.abs(hi)) for lo, hi in (q1, q2, q3))
    return out + ((tool.bound(path, s_lo, s_hi, ranges, 1) * sd_hi[:, 0])[:, None],)


def motion_values(path: PiecewisePath, f: FilteredProfile, t: np.ndarray, tool: ToolRate | None = None):
    """The values :func:`motion_bound` bounds, at times ``t`` (K,): ``(qd, qdd, qddd[, tool speed (K, 1)])``."""
    s, sd, sdd, sddd = f.at(t)
    out = joint_motion(path, s, sd, sdd, sddd)[1:]
    if tool is None:
        return out
    return out + ((tool.rate(path.q(s), path.derivative(s, 1)) * sd)[:, None],)


def limit_ratio(values, limits) -> np.ndarray:
    """(K,) the time scale each row needs: the largest of ``|qd| / v``, ``sqrt(|qdd| / a)``,
    ``cbrt(|qddd| / j)`` over the joints, from ``values`` ``(|qd|, |qdd|, |qddd|)`` each (K, dof)
    (and, with a fourth value and limit, ``|tool speed| / v_tool``: a speed, as ``qd``)."""
    orders = (1, 2, 3, 1)
    return np.max([np.max(np.abs(x) / lim, axis=1) ** (1.0 / order)
                   for order, x, lim in zip(orders, values, limits)], axis=0)


def proven_scale(path: PiecewisePath, f: FilteredProfile, limits, tolerance: float = BOUND_TOLERANCE,
                 ceiling: float = np.inf, tool: ToolRate | None = None) -> float:
    """The time scale that brings every joint limit of ``f`` (and ``tool``'s speed) to at most 1 at
    every instant: the largest
    :func:`limit_ratio` of :func:`motion_bound` over intervals covering ``[0, f.duration]``, the
    intervals that could hold the peak split (:data:`SPLIT` ways, at most :data:`SPLIT_ROUNDS` times)
    until their bound is within ``tolerance`` of the largest value met at their ends (a lower bound
    of the true peak). The answer is never below the true peak; it exceeds it by at most
    ``tolerance`` unless the rounds run out. Infinity when the motion's values at its breakpoints
    already need more than ``ceiling`` (a candidate that cannot win)."""
    t = np.unique(np.r_[0.0, f.breakpoints(), f.duration])
    t = t[(t >= 0.0) & (t <= f.duration)]
    ta, tb = t[:-1], t[1:]
    done = 0.0  # the largest bound of the intervals settled
    if tool is not None:
        limits = tuple(limits) + (np.array([tool.max]),)
    peak = float(np.max(limit_ratio(motion_values(path, f, t, tool), limits)))
    if peak > ceiling:
        return np.inf
    for _ in range(SPLIT_ROUNDS):
        bound = limit_ratio(motion_bound(path, f, ta, tb, tool), limits)
        open_ = bound > peak * (1.0 + tolerance)
        done = max(done, float(np.max(bound[~open_], initial=0.0)))
        if not open_.any():
            return done
        ta, tb = ta[open_], tb[open_]
        cut = ta[:, None] + (tb - ta)[:, None] * (np.arange(SPLIT + 1) / SPLIT)
        ta, tb = cut[:, :-1].ravel(), cut[:, 1:].ravel()
        peak = max(peak, float(np.max(limit_ratio(motion_values(path, f, tb, tool), limits))))
    return max(done, float(np.max(limit_ratio(motion_bound(path, f, ta, tb, tool), limits))))


def required_scale(path: PiecewisePath, f: FilteredProfile, velocity, acceleration, jerk,
                   tool: ToolRate | None, ceiling: float = np.inf) -> float:
    """The time scale ``k`` that brings ``f``'s proven bound (:func:`proven_scale`) to the tightest
    joint limit or the tool's speed limit; over ``1 - LIMIT_MARGIN`` (rounding).
    Infinity as soon as it is seen to exceed ``ceiling``."""
    k = proven_scale(path, f, (velocity, acceleration, jerk), ceiling=ceiling, tool=tool)
    return float(k) / (1.0 - LIMIT_MARGIN)


def refine(consider, around) -> None:
    """``consider`` the neighbours of ``around`` = ``(fraction, width, cap)`` (:data:`REFINE`)."""
    fraction, width, cap = around
    for df in REFINE[0]:
        for dw in REFINE[1]:
            if df != 1.0 or dw != 1.0:
                consider(fraction * df, width * dw, cap)
    for dc in REFINE[2]:
        if min(cap * dc, 1.0) != cap:
            consider(fraction, width, cap * dc)


def jerk_limited(path: PiecewisePath, velocity, acceleration, jerk, n: int = 1000,
                 tool: ToolRate | None = None) -> FilteredProfile:
    """The shortest of the filtered, time-scaled profiles of ``path`` (from rest to rest) over the
    searched acceleration fractions, filter lengths and velocity caps (see the module's text): the
    grid :data:`FRACTIONS` x :data:`WIDTHS` and the neighbours of its best (:data:`REFINE`), then
    that best with :data:`VELOCITY_CAPS` and, if one of them is shorter, its neighbours."""
    velocity, acceleration, jerk = (np.asarray(v, dtype=float) for v in (velocity, acceleration, jerk))
    bases: dict[tuple[float, float], Profile] = {}
    best = None

    def consider(fraction: float, width: float, cap: float = 1.0) -> None:
        nonlocal best
        cap = min(cap, 1.0)
        if (fraction, cap) not in bases:
            check()
            bases[fraction, cap] = topp(path, velocity * cap, acceleration * fraction, n, tool)
        f = FilteredProfile(bases[fraction, cap], width * float(np.max(2 * fraction * acceleration / jerk)))
        ceiling = np.inf if best is None else best[0].duration / f.duration
        f = FilteredProfile(f.base, f.tau, required_scale(path, f, velocity, acceleration, jerk, tool, ceiling))
        if best is None or f.duration < best[0].duration:
            best = (f, fraction, width, cap)

    for fraction in FRACTIONS:
        for width in WIDTHS:
            consider(fraction, width)
    refine(consider, best[1:])
    _, fraction, width, _ = best
    for cap in VELOCITY_CAPS:
        for w in sorted({CAP_WIDTH, width}):
            consider(fraction, w, cap)
    if best[3] != 1.0:  # a cap made it shorter: around it too
        refine(consider, best[1:])
    return best[0]
