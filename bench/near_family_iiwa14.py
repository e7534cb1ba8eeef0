"""The real iiwa14 (rtb-data's URDF, shoulder axes 0.44 mm apart) with one joint locked: every solution
of ``n`` targets (``python -m bench.near_family_iiwa14 [n]``), random and near a stretched elbow.

Per row: the family read, wall and CPU microseconds per target (one batch, ``limits="respect"``),
how many targets the answer says are complete, and how many of those miss their generating
configuration (a claim that is false, unless the target is singular: there the list holds
representatives flagged ``singular``).
"""

from __future__ import annotations

import sys
import time

import numpy as np

from kinematics import compile_model
from kinematics.algorithms.ik_all import all_solutions

from .redundancy import iiwa14_model

#: (the locked joint, its column, its value)
LOCKS = (("joint_a3", 2, 0.4), ("joint_a7", 6, -1.371))


def run(n: int = 500) -> list[str]:
    model, link = iiwa14_model(), "tool0"
    poe = compile_model(model)
    lo, hi = model.lower_limits, model.upper_limits
    lines = ["| locked, targets | family | us per target (wall) | us per target (CPU) | complete | "
             "complete but the generating configuration missing |", "|" + "---|" * 6]
    for joint, col, v in LOCKS:
        for label, elbow in (("random", False), ("elbow 0.03-0.12", True)):
            rng = np.random.default_rng(1)
            q = lo + (hi - lo) * rng.random((n, 7))
            q[:, col] = v
            if elbow:
                q[:, 3] = rng.uniform(0.03, 0.12, n) * rng.choice([-1, 1], n)
            T = poe.fk(q, [link])[:, 0]
            all_solutions(model, link, T[:5], locked={joint: v})  # compile and warm the caches
            wall, cpu = time.perf_counter(), time.process_time()
            s = all_solutions(model, link, T, locked={joint: v})
            wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
            false_claims = sum(
                bool(s.complete[i]) and (not s.count[i] or np.abs(np.angle(np.exp(1j * (s.q[i, :s.count[i]] - q[i]))))
                                         .max(axis=1).min() > 1e-6) for i in range(n))
            near = " (near)" if s.family.near else ""
            lines.append(f"| {joint} locked, {label} | {s.family.name}{near} | {wall / n * 1e6:.0f} | "
                         f"{cpu / n * 1e6:.0f} | {int(s.complete.sum())}/{n} | {false_claims} |")
            print(lines[-1], flush=True)
    return lines


if __name__ == "__main__":
    print("\n".join(run(*(int(a) for a in sys.argv[1:]))))
