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
jerks by ``k^3``; ``k`` is the largest of ``|qdot| / v``, ``sqrt(|qddot| / a)``, ``cbrt(|qdddot| /
j)`` (and the tool's speed ratio) over a dense sampling of the filtered motion (its breakpoints
included), over ``1 - JERK_MARGIN``. The acceleration fraction given to the time-optimal profile
and the filter length are searched over a small set (:data:`FRACTIONS`, :data:`WIDTHS`), the
shortest result kept.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...engine.cancel import check
from .path import PiecewisePath
from .topp import Profile, ToolRate, joint_motion, topp

#: fractions of the acceleration limits the time-optimal profile is given before filtering
FRACTIONS = (0.3, 0.45, 0.6, 0.75, 0.9)
#: filter lengths, as multiples of ``max_j 2 fraction a_j / j_j`` (the time a joint's acceleration
#: takes to swing through its range at its jerk limit)
WIDTHS = (0.5, 0.75, 1.0, 1.5)
#: the sampled ratios are held below ``1 - JERK_MARGIN`` (the motion between samples)
JERK_MARGIN = 2e-3
#: uniform samples of the filtered motion when computing its time scale (its breakpoints are added):
#: fewer while comparing the candidates, more for the one kept
SEARCH_SAMPLES = 4000
DENSE_SAMPLES = 20000


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


def required_scale(path: PiecewisePath, f: FilteredProfile, velocity, acceleration, jerk,
                   tool: ToolRate | None, samples: int = DENSE_SAMPLES) -> float:
    """The time scale ``k`` that brings the sampled motion of ``f`` to its tightest limit."""
    t = np.unique(np.r_[np.linspace(0.0, f.duration, samples), f.breakpoints(),
                        np.maximum(f.breakpoints() - 1e-9 * f.duration, 0.0)])
    t = t[t <= f.duration]
    s, sd, sdd, sddd = f.at(t)
    q, qd, qdd, qddd = joint_motion(path, s, sd, sdd, sddd)
    ratios = [np.max(np.abs(qd) / velocity), np.sqrt(np.max(np.abs(qdd) / acceleration)),
              np.cbrt(np.max(np.abs(qddd) / jerk))]
    if tool is not None:
        ratios.append(np.max(tool.rate(q, path.derivative(s, 1)) * sd) / tool.max)
    return float(max(ratios)) / (1.0 - JERK_MARGIN)


def jerk_limited(path: PiecewisePath, velocity, acceleration, jerk, n: int = 1000,
                 tool: ToolRate | None = None) -> FilteredProfile:
    """The shortest of the filtered, time-scaled profiles of ``path`` (from rest to rest) over the
    searched acceleration fractions and filter lengths (see the module's text)."""
    velocity, acceleration, jerk = (np.asarray(v, dtype=float) for v in (velocity, acceleration, jerk))
    best = None
    for fraction in FRACTIONS:
        check()
        base = topp(path, velocity, acceleration * fraction, n, tool)
        unit = float(np.max(2 * fraction * acceleration / jerk))
        for width in WIDTHS:
            f = FilteredProfile(base, unit * width)
            k = required_scale(path, f, velocity, acceleration, jerk, tool, SEARCH_SAMPLES)
            f = FilteredProfile(base, unit * width, k)
            if best is None or f.duration < best.duration:
                best = f
    check()
    unscaled = FilteredProfile(best.base, best.tau)
    return FilteredProfile(best.base, best.tau, required_scale(path, unscaled, velocity, acceleration, jerk, tool))
