"""Trajectories (``--only trajectory``, writes ``RESULTS_TRAJECTORY.md``): random 6-joint (UR5
limits) and 7-joint (Panda arm limits) spline paths through 3 to 8 waypoints, half on each robot,
and a tenth as many again on a third arm (xArm7), timed by ours and by TOPP-RA (PyPI ``toppra``,
the `bench` extra) at 2,000 grid points on the same path (``SplineInterpolator`` is the same
not-a-knot spline), same velocity and acceleration limits.

Reported: success rate, the duration ratio ours / TOPP-RA (goal: at most 1.005), the paths whose
returned motion exceeds a limit at 1 kHz, judged from the returned q itself by finite differences
(first differences / h against the velocity limit, second differences / h^2 against the
acceleration limit; relative slack 1e-6 for rounding), for ours and for TOPP-RA, and the compute
time ratio (median per path, CPU time of this thread). Then jerk-limited durations on a subset
(the first tenth of the paths, jerk = 10 x acceleration per second) against our
acceleration-limited optimum, the jerk judged the same way (third differences / h^3) and from the
exact derivatives at 20 kHz; and, where a state-to-state reference fits, rest-to-rest straight
lines (two waypoints) against Ruckig (PyPI ``ruckig``) with phase synchronisation, whose motion
is then the same straight line, jerk-limited and time-optimal along it.

``python -m bench.trajectory [--quick] [--paths N] [--output bench/RESULTS_TRAJECTORY.md]``.
"""

from __future__ import annotations

import os
import sys

import numpy as np

from kinematics.algorithms.trajectory.path import spline_path
from kinematics.algorithms.trajectory.plan import plan, sample_times
from kinematics.io.catalogue import default_catalogue

from .common import CLOCK, CLOCK_NAME, Report, table

GRID = 2000
RATE = 1000.0
#: rate of the exact-derivative check of the jerk-limited motions, Hz
FINE_RATE = 20000.0
SLACK = 1e-6
#: the robots of the headline (alternating), and the third arm (a tenth as many paths again)
ROBOTS = (("ur5", 6), ("panda", 7))
THIRD = ("xarm7", 7)
#: jerk limits of the jerk-limited tables, per second times the acceleration limits
JERK_PER_ACCELERATION = 10.0


def random_paths(n: int, seed: int = 0, robots=ROBOTS, waypoints=(3, 9)):
    """``(robot, W, v, a)``: n random spline problems, the robots in turn, inside the joint limits."""
    rng = np.random.default_rng(seed)
    cat = default_catalogue()
    out = []
    for k in range(n):
        rid, dof = robots[k % len(robots)]
        model = cat.get(rid)
        v = np.array([j.limits.velocity for j in model.moving_joints][:dof])
        lo, hi = model.lower_limits[:dof], model.upper_limits[:dof]
        lo, hi = np.maximum(lo, -np.pi), np.minimum(hi, np.pi)
        mid, half = (lo + hi) / 2, (hi - lo) / 2
        m = int(rng.integers(*waypoints))
        W = mid + 0.6 * half * rng.uniform(-1, 1, (m, dof))
        a = rng.uniform(2.0, 10.0, dof)
        out.append((rid, W, v, a))
    return out


def fd_ratios(q: np.ndarray, h: float, limits) -> list[float]:
    return [float(np.max(np.abs(np.diff(q, k, axis=0)) / h**k / lim)) for k, lim in enumerate(limits, start=1)]


def toppra_trajectory(ta, W, v, a):
    from toppra import algorithm, constraint

    path = ta.SplineInterpolator(np.linspace(0, 1, len(W)), W)
    inst = algorithm.TOPPRA([constraint.JointVelocityConstraint(np.c_[-v, v]),
                             constraint.JointAccelerationConstraint(np.c_[-a, a])], path,
                            gridpoints=np.linspace(0, 1, GRID + 1), parametrizer="ParametrizeConstAccel")
    return inst.compute_trajectory()


def timed(fn):
    """``(result or None, CPU seconds)``: a failure (an exception, None) counts as no result."""
    t0 = CLOCK()
    try:
        out = fn()
    except Exception:  # noqa: BLE001 - counted as a failure
        out = None
    return out, CLOCK() - t0


def time_optimal_table(report: Report, problems, title: str) -> None:
    import toppra as ta

    ta.setup_logging("WARNING")
    rows = {}
    for done, (rid, W, v, a) in enumerate(problems):
        if done and done % 100 == 0:
            print(f"  {done} of {len(problems)} paths", file=sys.stderr, flush=True)
        r = rows.setdefault(rid, {"n": 0, "ok": 0, "ok_ta": 0, "ratio": [], "viol": 0, "viol_ta": 0, "t": [],
                                  "t_ta": [], "worst": [], "worst_ta": []})
        r["n"] += 1
        ours, elapsed = timed(lambda: plan(spline_path(W), v, a, n=GRID))
        theirs, elapsed_ta = timed(lambda: toppra_trajectory(ta, W, v, a))
        r["t"].append(elapsed)
        r["t_ta"].append(elapsed_ta)
        if ours is not None and np.isfinite(ours.duration):
            r["ok"] += 1
            q = ours.sample(sample_times(ours.duration, RATE)[:-1])[0]
            worst = max(fd_ratios(q, 1 / RATE, [v, a]))
            r["worst"].append(worst)
            r["viol"] += worst > 1 + SLACK
        if theirs is not None and np.isfinite(theirs.duration):
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
        both = [(x, y) for x, y in zip(r["t"], r["t_ta"])]
        body.append([rid, r["n"], f"{100 * r['ok'] / r['n']:.1f} %", f"{100 * r['ok_ta'] / r['n']:.1f} %",
                     f"{np.median(ratio):.4f}", f"**{ratio.max():.4f}**", f"{r['viol']}", f"{max(r['worst']):.6f}",
                     f"{r['viol_ta']}", f"{max(r['worst_ta']):.6f}", f"{1e3 * np.median(r['t']):.1f}",
                     f"{1e3 * np.median(r['t_ta']):.1f}", f"**{np.median([x / y for x, y in both]):.2f}**"])
    report.add(title,
               table(["robot", "paths", "ours ok", "TOPP-RA ok", "duration ratio (median)", "duration ratio (max)",
                      "ours: paths over a limit at 1 kHz", "ours: worst limit ratio", "TOPP-RA: paths over",
                      "TOPP-RA: worst ratio", "ours ms (median)", "TOPP-RA ms (median)", "time ratio (median)"], body),
               note="Limits judged from the returned q sampled at 1 kHz (finite differences). Ours holds the "
                    "limits on whole grid intervals (exact polynomial bounds), so it is never shorter than "
                    "TOPP-RA's grid-point optimum by more than its discretisation. Duration ratios over the "
                    "paths both planned; times by " + CLOCK_NAME + ".")


def jerk_check(timing, v, a, j):
    """The worst limit ratio from finite differences of q at 1 kHz, and from the exact derivatives at
    :data:`FINE_RATE`."""
    q = timing.sample(sample_times(timing.duration, RATE)[:-1])[0]
    fd = max(fd_ratios(q, 1 / RATE, [v, a, j]))
    _, qd, qdd, qddd = timing.sample(sample_times(timing.duration, FINE_RATE))
    exact = max(float(np.max(np.abs(x) / lim)) for x, lim in zip((qd, qdd, qddd), (v, a, j)))
    return fd, exact


def jerk_table(report: Report, problems) -> None:
    rows = []
    for rid, W, v, a in problems:
        path = spline_path(W)
        j = JERK_PER_ACCELERATION * a
        timing, elapsed = timed(lambda: plan(path, v, a, j))
        best = plan(path, v, a).duration
        if timing is None:
            rows.append((rid, np.nan, np.inf, np.inf, elapsed, False))
            continue
        rows.append((rid, timing.duration / best, *jerk_check(timing, v, a, j), elapsed, True))
    body = []
    for rid in dict(ROBOTS + (THIRD,)):
        sel = [x for x in rows if x[0] == rid]
        if sel:
            ratios = np.array([x[1] for x in sel if x[5]])
            body.append([rid, len(sel), f"{100 * np.mean([x[5] for x in sel]):.1f} %", f"{np.median(ratios):.3f}",
                         f"{ratios.max():.3f}", sum(x[2] > 1 + SLACK for x in sel), f"{max(x[2] for x in sel):.6f}",
                         sum(x[3] > 1 + SLACK for x in sel), f"{max(x[3] for x in sel):.6f}",
                         f"{1e3 * np.median([x[4] for x in sel]):.0f}"])
    report.add(f"Jerk-limited spline trajectories ({len(rows)} paths: the first of the random paths above; "
               f"jerk = {JERK_PER_ACCELERATION:g} x acceleration)",
               table(["robot", "paths", "ok", "duration / acceleration-limited optimum (median)", "(max)",
                      "paths over a limit at 1 kHz (finite differences of q)", "worst ratio",
                      f"paths over at {FINE_RATE / 1000:g} kHz (exact derivatives)", "worst ratio",
                      "ms (median)"], body),
               note="Jerk-limited: the time-optimal profile at a fraction of the acceleration limits, smoothed by "
                    "a moving-average filter on the path parameter and time-scaled so that proven bounds of "
                    "every joint's velocity, acceleration and jerk over whole time intervals meet the tightest "
                    "limit (not samples). TOPP-RA has no jerk limits.")


def ruckig_table(report: Report, problems) -> None:
    try:
        from ruckig import InputParameter, Result, Ruckig, Synchronization, Trajectory
    except ImportError:
        report.add("Jerk-limited rest-to-rest straight lines against Ruckig", "ruckig is not installed: not run.")
        return
    rows = []
    for rid, W, v, a in problems:
        dof = W.shape[1]
        j = JERK_PER_ACCELERATION * a
        otg, inp, traj = Ruckig(dof), InputParameter(dof), Trajectory(dof)
        inp.current_position, inp.target_position = W[0].tolist(), W[1].tolist()
        inp.max_velocity, inp.max_acceleration, inp.max_jerk = v.tolist(), a.tolist(), j.tolist()
        inp.synchronization = Synchronization.Phase
        result, elapsed_r = timed(lambda: otg.calculate(inp, traj))
        timing, elapsed = timed(lambda: plan(spline_path(W), v, a, j))
        ok = timing is not None and result in (Result.Working, Result.Finished)
        rows.append((rid, timing.duration / traj.duration if ok else np.nan,
                     jerk_check(timing, v, a, j)[1] if timing is not None else np.inf, elapsed, elapsed_r, ok))
    body = []
    for rid in dict(ROBOTS):
        sel = [x for x in rows if x[0] == rid]
        ratios = np.array([x[1] for x in sel if x[5]])
        body.append([rid, len(sel), f"{100 * np.mean([x[5] for x in sel]):.1f} %", f"{np.median(ratios):.3f}",
                     f"{ratios.min():.3f}", f"{ratios.max():.3f}", sum(x[2] > 1 + SLACK for x in sel),
                     f"{1e3 * np.median([x[3] for x in sel]):.0f}", f"{1e3 * np.median([x[4] for x in sel]):.3f}"])
    report.add(f"Jerk-limited rest-to-rest straight lines ({len(rows)} random pairs of configurations) against "
               f"Ruckig (phase synchronisation)",
               table(["robot", "pairs", "both ok", "duration ratio ours / Ruckig (median)", "(min)", "(max)",
                      f"ours: over a limit at {FINE_RATE / 1000:g} kHz", "ours ms (median)",
                      "Ruckig ms (median)"], body),
               note="Ruckig with phase synchronisation moves every joint on the same normalised profile, so its "
                    "motion is the straight line between the two configurations, jerk-limited and time-optimal "
                    "along it: the reference for our jerk-limited timing of the same two-waypoint path. Same "
                    f"velocity, acceleration and jerk ({JERK_PER_ACCELERATION:g} x acceleration) limits.")


def run(report: Report, quick: bool = False, paths: int | None = None) -> None:
    n = paths or (60 if quick else 1000)
    problems = random_paths(n)
    third = random_paths(max(2, n // 10), seed=1, robots=(THIRD,))
    plan(spline_path(problems[0][1]), problems[0][2], problems[0][3])  # compile the passes
    time_optimal_table(report, problems, f"Time-optimal spline trajectories, {n} random paths ({n - n // 2} UR5, "
                                         f"{n // 2} Panda), against TOPP-RA at {GRID} grid points")
    time_optimal_table(report, third, f"The same on a third arm: {len(third)} random xArm7 paths")
    jerk_table(report, problems[:max(4, n // 10)])
    ruckig_table(report, random_paths(max(4, n // 10), seed=2, waypoints=(2, 3)))


if __name__ == "__main__":
    import argparse

    from threadpoolctl import threadpool_limits

    from .common import machine_info
    from .run_all import write_report

    p = argparse.ArgumentParser(prog="python -m bench.trajectory", description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--paths", type=int, default=None, help="how many random paths (default 1000, 60 with --quick)")
    p.add_argument("--output", help="write the tables to this file (with the machine and the command)")
    args = p.parse_args()
    wall0 = os.times().elapsed
    report = Report()
    with threadpool_limits(limits=1, user_api="blas"):  # as run_all: single-threaded, like TOPP-RA
        header = machine_info()
        print(header, flush=True)
        run(report, quick=args.quick, paths=args.paths)
    elapsed = os.times().elapsed - wall0
    report.add("Machine load", f"load average at the end: {' '.join(f'{x:.2f}' for x in os.getloadavg())} "
                               f"(2 cores shared with other work); the run took {elapsed:.0f} s of wall time.")
    if args.output:
        write_report(args.output, "Benchmark results (trajectory)", report.sections,
                     "python -m bench.trajectory " + " ".join(sys.argv[1:]), header, elapsed, 1)
