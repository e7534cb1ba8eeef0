"""Trajectories (``--only trajectory``, writes ``RESULTS_TRAJECTORY.md``): random 6-joint (UR5
limits) and 7-joint (Panda arm limits) spline paths through 3 to 8 waypoints, timed by ours and by
TOPP-RA (PyPI ``toppra``, the `bench` extra) at 2,000 grid points on the same path
(``SplineInterpolator`` is the same not-a-knot spline), same velocity and acceleration limits.

Reported: success rate, the duration ratio ours / TOPP-RA (goal: at most 1.005), the paths whose
returned motion exceeds a limit at 1 kHz, judged from the returned q itself by finite differences
(first differences / h against the velocity limit, second differences / h^2 against the
acceleration limit; relative slack 1e-6 for rounding), for ours and for TOPP-RA, and the compute
time ratio (median per path). Then jerk-limited durations on a subset (jerk = 10 x acceleration per
second) against our acceleration-limited optimum, with the jerk judged the same way (third
differences / h^3). Ruckig is not run: it plans state to state, not along a given path.

``python -m bench.trajectory [--quick] [--paths N]``.
"""

from __future__ import annotations

import time

import numpy as np

from kinematics.algorithms.trajectory.path import spline_path
from kinematics.algorithms.trajectory.plan import plan, sample_times
from kinematics.io.catalogue import default_catalogue

from .common import Report, table

GRID = 2000
RATE = 1000.0
SLACK = 1e-6
ROBOTS = (("ur5", 6), ("panda", 7))


def random_paths(n: int, seed: int = 0):
    """``(robot, W, v, a)``: n random spline problems, half on each robot, inside the joint limits."""
    rng = np.random.default_rng(seed)
    cat = default_catalogue()
    out = []
    for k in range(n):
        rid, dof = ROBOTS[k % 2]
        model = cat.get(rid)
        v = np.array([j.limits.velocity for j in model.moving_joints][:dof])
        lo, hi = model.lower_limits[:dof], model.upper_limits[:dof]
        lo, hi = np.maximum(lo, -np.pi), np.minimum(hi, np.pi)
        mid, half = (lo + hi) / 2, (hi - lo) / 2
        m = int(rng.integers(3, 9))
        W = mid + 0.6 * half * rng.uniform(-1, 1, (m, dof))
        a = rng.uniform(2.0, 10.0, dof)
        out.append((rid, W, v, a))
    return out


def fd_ratios(q: np.ndarray, h: float, limits) -> list[float]:
    return [float(np.max(np.abs(np.diff(q, k, axis=0)) / h**k / lim)) for k, lim in enumerate(limits, start=1)]


def toppra_duration(ta, W, v, a):
    from toppra import algorithm, constraint

    path = ta.SplineInterpolator(np.linspace(0, 1, len(W)), W)
    inst = algorithm.TOPPRA([constraint.JointVelocityConstraint(np.c_[-v, v]),
                             constraint.JointAccelerationConstraint(np.c_[-a, a])], path,
                            gridpoints=np.linspace(0, 1, GRID + 1), parametrizer="ParametrizeConstAccel")
    return inst.compute_trajectory()


def run(report: Report, quick: bool = False, paths: int | None = None) -> None:
    import toppra as ta

    ta.setup_logging("WARNING")
    n = paths or (60 if quick else 1000)
    n_jerk = max(4, n // 10)
    problems = random_paths(n)
    plan(spline_path(problems[0][1]), problems[0][2], problems[0][3])  # compile the passes
    rows = {}
    for rid, W, v, a in problems:
        r = rows.setdefault(rid, {"n": 0, "ok": 0, "ok_ta": 0, "ratio": [], "viol": 0, "viol_ta": 0, "t": [],
                                  "t_ta": [], "worst": [], "worst_ta": []})
        r["n"] += 1
        t0 = time.perf_counter()
        try:
            ours = plan(spline_path(W), v, a, n=GRID)
        except Exception:  # noqa: BLE001 - counted as a failure
            ours = None
        r["t"].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        try:
            theirs = toppra_duration(ta, W, v, a)
        except Exception:  # noqa: BLE001
            theirs = None
        r["t_ta"].append(time.perf_counter() - t0)
        if ours is not None and np.isfinite(ours.duration):
            r["ok"] += 1
            q = ours.sample(sample_times(ours.duration, RATE)[:-1])[0]
            worst = max(fd_ratios(q, 1 / RATE, [v, a]))
            r["worst"].append(worst)
            r["viol"] += worst > 1 + SLACK
        if theirs is not None:
            r["ok_ta"] += 1
            tt = np.arange(0, theirs.duration, 1 / RATE)
            worst = max(fd_ratios(theirs(tt), 1 / RATE, [v, a]))
            r["worst_ta"].append(worst)
            r["viol_ta"] += worst > 1 + SLACK
            if ours is not None:
                r["ratio"].append(ours.duration / theirs.duration)
    body = []
    for rid, r in rows.items():
        ratio = np.array(r["ratio"])
        body.append([rid, r["n"], f"{100 * r['ok'] / r['n']:.1f} %", f"{100 * r['ok_ta'] / r['n']:.1f} %",
                     f"{np.median(ratio):.4f}", f"**{ratio.max():.4f}**", f"{r['viol']}", f"{max(r['worst']):.6f}",
                     f"{r['viol_ta']}", f"{max(r['worst_ta']):.6f}", f"{1e3 * np.median(r['t']):.1f}",
                     f"{1e3 * np.median(r['t_ta']):.1f}", f"**{np.median(np.array(r['t']) / np.array(r['t_ta'])):.2f}**"])
    report.add(f"Time-optimal spline trajectories, {n} random paths, against TOPP-RA at {GRID} grid points",
               table(["robot", "paths", "ours ok", "TOPP-RA ok", "duration ratio (median)", "duration ratio (max)",
                      "ours: paths over a limit at 1 kHz", "ours: worst limit ratio", "TOPP-RA: paths over",
                      "TOPP-RA: worst ratio", "ours ms (median)", "TOPP-RA ms (median)", "time ratio (median)"], body),
               note="Limits judged from the returned q sampled at 1 kHz (finite differences). Ours holds the "
                    "limits on whole grid intervals (exact polynomial bounds), so it is never shorter than "
                    "TOPP-RA's grid-point optimum by more than its discretisation.")
    jrows = []
    for rid, W, v, a in problems[:n_jerk]:
        path = spline_path(W)
        j = 10 * a
        t0 = time.perf_counter()
        timed = plan(path, v, a, j)
        elapsed = time.perf_counter() - t0
        best = plan(path, v, a).duration
        q = timed.sample(sample_times(timed.duration, RATE)[:-1])[0]
        jrows.append((rid, timed.duration / best, max(fd_ratios(q, 1 / RATE, [v, a, j])), elapsed))
    jb = []
    for rid in dict(ROBOTS):
        sel = [x for x in jrows if x[0] == rid]
        if sel:
            ratios = np.array([x[1] for x in sel])
            jb.append([rid, len(sel), f"{np.median(ratios):.3f}", f"{ratios.max():.3f}",
                       sum(x[2] > 1 + SLACK for x in sel), f"{max(x[2] for x in sel):.6f}",
                       f"{1e3 * np.median([x[3] for x in sel]):.0f}"])
    report.add(f"Jerk-limited spline trajectories ({len(jrows)} of the paths, jerk = 10 x acceleration)",
               table(["robot", "paths", "duration / acceleration-limited optimum (median)", "(max)",
                      "paths over a limit at 1 kHz", "worst limit ratio", "ms (median)"], jb),
               note="Jerk-limited: the time-optimal profile at a fraction of the acceleration limits, smoothed by "
                    "a moving-average filter on the path parameter and time-scaled to the tightest limit. "
                    "TOPP-RA has no jerk limits.")


if __name__ == "__main__":
    import argparse

    p = argparse.ArgumentParser(prog="python -m bench.trajectory", description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--paths", type=int, default=None, help="how many random paths (default 1000, 60 with --quick)")
    args = p.parse_args()
    run(Report(), quick=args.quick, paths=args.paths)
