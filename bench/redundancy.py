"""A 7-joint arm's self-motion, our own timings (``python -m bench.redundancy``).

Per arm of the catalogue (the Panda, the LWR, the xArm7; the default parameter of each): ``n``
random configurations within the limits, their pose as the target. Reported: microseconds per
(target, value) of the slices at 16 values spread over the parameter's limits (``limits="respect"``,
one batch), in-limit solutions per target, how often the generating configuration is listed at its
own value, and milliseconds per target of the intervals and of the best point (``select="margin"``).

The comparison with ssik in the same run (the convention of the other benches) is not written yet.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from kinematics import compile_model, default_catalogue
from kinematics.algorithms import ik_redundant as red
from kinematics.algorithms import ik_self_motion as sm

ARMS = (("panda", "panda_link8"), ("kuka_lwr4", "tool"), ("xarm7", "link_eef"))


def run(n: int = 100, whole: int = 3) -> None:
    cat = default_catalogue()
    for name, link in ARMS:
        model = cat.get(name)
        motion = red.SelfMotion(model, link)
        rng = np.random.default_rng(0)
        lo, hi = model.lower_limits, model.upper_limits
        q = lo + (hi - lo) * rng.random((n, model.dof))
        T = compile_model(model).fk(q, [link])[:, 0]
        V = np.broadcast_to(np.linspace(motion.lower, motion.upper, 16), (n, 16))
        red.slices(motion, T[:2], V[:2], "respect")  # compile and warm the caches
        t = time.perf_counter()
        Q, P, count, *_ = red.slices(motion, T, V, "respect")
        per_pair = (time.perf_counter() - t) / V.size
        own = red.slices(motion, T, q[:, motion.column][:, None], "respect")
        cols = motion.chain.columns
        found = sum(bool(own[2][i]) and np.abs(own[0][i, :own[2][i]][:, cols] - q[i, cols]).max(axis=1).min() < 1e-8
                    for i in range(n))
        t = time.perf_counter()
        pieces, branches = sm.intervals(motion, T[:whole])
        t_int = (time.perf_counter() - t) / whole
        t = time.perf_counter()
        sm.best(motion, T[:whole], sm.Objective("margin"), pieces, branches)
        t_best = (time.perf_counter() - t) / whole
        print(f"{name} ({motion.joint}, {motion.cost}): {per_pair * 1e6:.0f} us per (target, value); "
              f"{count.mean():.1f} in-limit solutions per target over 16 values; generating configuration listed "
              f"{found}/{n}; intervals {t_int * 1e3:.0f} ms and best point {t_best * 1e3:.0f} ms per target")


if __name__ == "__main__":
    run(*(int(a) for a in sys.argv[1:]))
