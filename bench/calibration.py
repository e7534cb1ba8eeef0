"""Kinematic calibration on synthetic truth, as calibration papers test it.

Per robot and measure: planted errors (1 mm and 1 mrad on every joint origin component, 10 mrad
on every zero, a random device frame about a metre away, a marker 12 cm off the flange), 100
random configurations measured with 20 um Gaussian noise per axis (poses: 20 urad per axis too),
40 held out, 60 fitted. Reported: the identified rank against the complete-and-minimal count
``4R + 2P + 6`` (poses) / ``+ 3`` (positions), the RMS before (nominal model, registered) and after,
the held-out RMS against the measurements and against the noise-free truth, the limit
``sigma sqrt(p / M)`` (p identified combinations, M fitted measurements), the function evaluations
and the wall time of one calibration (median of 5). Then: 3 planted 5 mm outliers with the linear
and the huber loss, and D-optimal against random poses (15 configurations, held-out error vs truth).

FIGAROH (``figaroh`` 1.0.2, 27 further packages) runs in a venv of its own on the same UR5 data:
``bench/figaroh_side_by_side.py`` writes ``bench/RESULTS_FIGAROH.md``.
"""

from __future__ import annotations

import time

import numpy as np

from kinematics.algorithms.calibration import calibrate, select_poses
from kinematics.algorithms.calibration.synthetic import experiment, plant
from kinematics.io.catalogue import default_catalogue

from .common import Report, table

ROBOTS = (("ur5", "tool0"), ("panda", "panda_link8"), ("puma560_standard", "link6"))
SIGMA = 20e-6


def _rms(e):
    return float(np.sqrt(np.mean(np.sum(e ** 2, axis=1))))


def _truth_rms(cal, truth, Q):
    return _rms(cal.error_model.predict(Q, cal.x)[:, :3, 3] - truth.predict(Q)[:, :3, 3])


def run(report: Report, quick: bool = False) -> None:
    cat = default_catalogue()
    repeats = 2 if quick else 5
    rows = []
    for mid, link in ROBOTS:
        model = cat.get(mid)
        link = link if link in model.links else model.links[-1]
        for measure in ("position", "pose"):
            rng = np.random.default_rng(3)
            truth, Q, data = experiment(model, link, measure, 100, rng, SIGMA)
            kw = {"positions": data} if measure == "position" else {"poses": data}
            times = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                cal = calibrate(model, link, Q, holdout=0.4, random_seed=1, **kw)
                times.append(time.perf_counter() - t0)
            joints = cal.error_model.joints
            R = sum(j.type != "prismatic" for j in joints)
            P = len(joints) - R
            count = 4 * R + 2 * P + (6 if measure == "pose" else 3)
            held = np.array(cal.holdout)
            limit = SIGMA * np.sqrt(cal.identifiable / (len(Q) - len(held)))
            truth_rms = _truth_rms(cal, truth, Q[held])
            rows.append([mid, measure, f"{R}R{P}P" if P else f"{R}R", count, cal.identifiable,
                         "yes" if count == cal.identifiable else "**no**",
                         f"{cal.rmse_before * 1e3:.2f} mm", f"{cal.rmse_after * 1e6:.1f}", f"{cal.holdout_rmse * 1e6:.1f}",
                         f"{truth_rms * 1e6:.1f}", f"{limit * 1e6:.1f}", f"{truth_rms / limit:.2f}",
                         f"{cal.condition_number:.3g}", cal.iterations, f"{np.median(times) * 1e3:.0f}"])
    report.add("Calibration: identified rank, held-out accuracy, time (60 fitted + 40 held-out measurements)",
               table(["robot", "measure", "joints", "4R+2P+6/3", "rank", "equal", "RMS before", "RMS after (um)",
                      "held-out RMS (um)", "held-out vs truth (um)", "limit sigma sqrt(p/M) (um)", "truth / limit",
                      "condition", "evaluations", "time (ms)"], rows),
               note=f"Noise sigma = {SIGMA * 1e6:.0f} um per axis, so the RMS of the Euclidean noise is "
                    f"{SIGMA * np.sqrt(3) * 1e6:.1f} um: the residuals after the fit and on held-out data sit at the "
                    "noise, and the error against the noise-free truth at about the limit. Time: one calibration "
                    "(registration, identification, the fits, statistics and the calibrated URDF), median of "
                    f"{repeats}.")

    # outliers
    model = cat.get("ur5")
    rng = np.random.default_rng(5)
    bad = [3, 17, 42]
    truth, Q, data = experiment(model, "tool0", "position", 100, rng, SIGMA, outliers=bad)
    rows = []
    for loss in ("linear", "huber"):
        cal = calibrate(model, "tool0", Q[:60], positions=data[:60], loss=loss)
        rows.append([loss, ", ".join(map(str, cal.outliers)) or "none", f"{cal.rmse_after * 1e6:.1f}",
                     f"{_truth_rms(cal, truth, Q[60:]) * 1e6:.1f}"])
    clean = calibrate(model, "tool0", np.delete(Q[:60], bad, 0), positions=np.delete(data[:60], bad, 0))
    rows.append(["linear, outliers removed by hand", "-", f"{clean.rmse_after * 1e6:.1f}",
                 f"{_truth_rms(clean, truth, Q[60:]) * 1e6:.1f}"])
    report.add("Calibration: 3 planted 5 mm outliers (ur5, positions, 60 measurements)",
               table(["loss", "named outliers", "RMS after (um; huber: the named outliers left out)",
                      "error vs truth on 40 others (um)"], rows),
               note=f"Planted at measurements {', '.join(map(str, bad))}.")

    # pose selection
    rows = []
    n = 15
    for mid, link in ROBOTS:
        model = cat.get(mid)
        link = link if link in model.links else model.links[-1]
        t0 = time.perf_counter()
        choice = select_poses(model, link, n, "position", random_seed=0, point=(0.05, 0.03, 0.1))
        t_sel = time.perf_counter() - t0
        test = model.sample_configurations(200, np.random.default_rng(99))
        errs = {"chosen": [], "random": []}
        for seed in range(2 if quick else 6):
            rng = np.random.default_rng(100 + seed)
            truth = plant(model, link, "position", rng)
            for label, Qs in (("chosen", choice.q), ("random", model.sample_configurations(n, rng))):
                cal = calibrate(model, link, Qs, positions=truth.measure(Qs, SIGMA, rng))
                errs[label].append(_truth_rms(cal, truth, test))
        rows.append([mid, n, f"{choice.log_det:.1f}", f"{choice.random_log_det:.1f}", f"{choice.condition_number:.3g}",
                     f"{choice.random_condition_number:.3g}", f"{np.mean(errs['chosen']) * 1e6:.1f}",
                     f"{np.mean(errs['random']) * 1e6:.1f}", f"{t_sel:.2f}"])
    report.add("Calibration: D-optimal poses against random ones (positions, 15 configurations)",
               table(["robot", "n", "log det chosen", "log det random", "condition chosen", "condition random",
                      "error vs truth, chosen (um)", "error vs truth, random (um)", "selection time (s)"], rows),
               note="Error vs truth: RMS over 200 fresh configurations of the calibrated prediction against the "
                    "noise-free truth, mean over planted robots (a new random set each time).")
