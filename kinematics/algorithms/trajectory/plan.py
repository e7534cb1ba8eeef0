"""A trajectory along a path: each part between stops (corners of a linear path without blends)
timed from rest to rest, time-optimal (:func:`.topp.topp`) or jerk-limited
(:func:`.jerk.jerk_limited`), the parts one after the other; sampled at any times."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .jerk import FilteredProfile, jerk_limited
from .path import PiecewisePath
from .topp import Profile, ToolRate, joint_motion, topp

#: ``method`` of the answers
TIME_OPTIMAL = "time-optimal reachability (piecewise-constant path acceleration, interval-bounded constraints)"
JERK_LIMITED = ("jerk-limited (FIR-filtered time-optimal profile, time-scaled to proven bounds of velocity, "
                "acceleration and jerk over whole intervals)")


@dataclass(frozen=True, eq=False)
class Timing:
    """A timed path: ``parts`` (path, profile) one after the other; ``starts`` their start times."""

    parts: tuple[tuple[PiecewisePath, Profile | FilteredProfile], ...]
    starts: np.ndarray
    duration: float
    method: str

    def sample(self, t: np.ndarray):
        """``(q, qd, qdd, qddd)`` (K, dof) at times ``t`` (K,); ``qddd`` is 0 where the path acceleration
        is piecewise constant (the time-optimal method: jerk is not limited there)."""
        t = np.asarray(t, dtype=float)
        dof = self.parts[0][0].dof
        out = [np.zeros((len(t), dof)) for _ in range(4)]
        which = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, len(self.parts) - 1)
        for k, (path, prof) in enumerate(self.parts):
            sel = which == k
            if not sel.any():
                continue
            local = t[sel] - self.starts[k]
            if isinstance(prof, FilteredProfile):
                values = joint_motion(path, *prof.at(local))
            else:
                s, sd, sdd = prof.at(local)
                values = joint_motion(path, s, sd, sdd) + (np.zeros((len(s), dof)),)
            for o, v in zip(out, values):
                o[sel] = v
        return tuple(out)


def plan(path: PiecewisePath, velocity, acceleration, jerk=None, n: int = 2000,
         tool: ToolRate | None = None) -> Timing:
    """Time ``path`` under per-joint ``velocity``, ``acceleration`` (and ``jerk``) limits and ``tool``'s
    speed on about ``n`` grid intervals over its whole length."""
    parts = []
    durations = []
    for part in path.split():
        share = max(50, int(round(n * part.length / path.length))) if path.length > 0 else 50
        if part.length == 0 or not np.any(part.coeffs[:, 1:]):
            continue  # no motion
        if jerk is None:
            prof = topp(part, velocity, acceleration, share, tool)
        else:
            prof = jerk_limited(part, velocity, acceleration, jerk, max(50, share // 2), tool)
        parts.append((part, prof))
        durations.append(prof.duration)
    if not parts:  # the path does not move: one rest sample
        still = PiecewisePath(np.array([0.0, 1.0]), path.coeffs[:1, :1])
        s = np.array([0.0, 1.0])
        parts = [(still, Profile(s, np.zeros(2), np.zeros(1), np.zeros(2)))]
        durations = [0.0]
    starts = np.r_[0.0, np.cumsum(durations)[:-1]]
    return Timing(tuple(parts), starts, float(np.sum(durations)), TIME_OPTIMAL if jerk is None else JERK_LIMITED)


def sample_times(duration: float, rate: float) -> np.ndarray:
    """``0, 1/rate, 2/rate, ...`` up to ``duration``, which is the last (the last step may be shorter)."""
    n = int(np.floor(duration * rate * (1 + 1e-12)))
    t = np.arange(n + 1) / rate
    t = t[t < duration - 1e-12 / rate]
    return np.r_[t, duration] if duration > 0 else np.zeros(1)
