"""FIGAROH (PyPI ``figaroh`` 1.0.2) side by side with our calibration, on the same ur5 position data.

Standalone: run with a separate venv that has figaroh; it is not imported by the tests nor by
``bench/run_all.py``, and figaroh is not a dependency of the project. Commands::

    python3 -m venv /tmp/figvenv && /tmp/figvenv/bin/pip install figaroh example-robot-data
    # 1. our synthetic data and our result (project venv)
    cd <checkout> && PYTHONPATH=$PWD <project venv>/bin/python bench/figaroh_side_by_side.py export /tmp/ur5_cal_data.npz
    # 2. FIGAROH on the same data (figaroh venv), writes bench/RESULTS_FIGAROH.md
    /tmp/figvenv/bin/python bench/figaroh_side_by_side.py figaroh /tmp/ur5_cal_data.npz bench/RESULTS_FIGAROH.md

The data are exactly those of bench/calibration.py (ur5, tool0, positions, rng seed 3: 1 mm / 1 mrad on
every joint origin component, 10 mrad on every zero, unknown device frame, marker 12 cm off the flange,
100 configurations with 20 um noise per axis; our calibrate(holdout=0.4, random_seed=1) splits 60 / 40
and FIGAROH is given the same 60 to fit and the same 40 to predict).
"""

from __future__ import annotations

import sys
import time

import numpy as np

SIGMA = 20e-6


def _rms(e):
    return float(np.sqrt(np.mean(np.sum(np.asarray(e) ** 2, axis=1))))


def export(path: str) -> None:
    from kinematics.algorithms.calibration import calibrate
    from kinematics.algorithms.calibration.synthetic import plant
    from kinematics.io.catalogue import default_catalogue

    model = default_catalogue().get("ur5")
    rng = np.random.default_rng(3)
    truth = plant(model, "tool0", "position", rng)
    Q = model.sample_configurations(100, rng)
    data = truth.measure(Q, SIGMA, rng)
    calibrate(model, "tool0", Q, holdout=0.4, random_seed=1, positions=data)  # warm-up (compilation)
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        cal = calibrate(model, "tool0", Q, holdout=0.4, random_seed=1, positions=data)
        times.append(time.perf_counter() - t0)
    held = np.array(cal.holdout)
    fit = np.setdiff1d(np.arange(len(Q)), held)
    tp = truth.predict(Q)[:, :3, 3]
    pred = cal.error_model.predict(Q, cal.x)[:, :3, 3]
    np.savez(path, Q=Q, measured=data, truth_positions=tp, fit=fit, held=held, ours_pred=pred,
             ours_rank=cal.identifiable, ours_rmse_after=cal.rmse_after, ours_time=float(np.median(times)),
             joint_names=np.array(model.joint_names))
    print(f"wrote {path}: ours rank {cal.identifiable}, held-out vs truth {_rms(pred[held] - tp[held]) * 1e6:.1f} um")


def _version(name):
    from importlib.metadata import version

    return version(name)


def _csv(path, names, Q, P):
    with open(path, "w") as f:
        f.write(",".join(["x1", "y1", "z1", *names]) + "\n")
        for q, p in zip(Q, P):
            f.write(",".join(f"{v:.12g}" for v in (*p, *q)) + "\n")


CONFIG = """\
schema_version: "2.0"
robot:
  name: ur5
tasks:
  calibration:
    type: kinematic_calibration
    kinematics:
      base_frame: universe
      tool_frame: tool0
    measurements:
      markers:
        - measurable_dof: [true, true, true, false, false, false]
    parameters:
      calibration_level: {level}
      include_non_geometric: false
      outlier_threshold: 0.05
      estimation:
        method: {method}
    data:
      source_file: {data}
      validation_data_file: {val}
"""


NOTES = """\
Same data as the ur5 / position row of RESULTS_CALIBRATION.md: 60 fitted, the same 40 held out; held-out
vs truth is the RMS of each calibrated prediction against the noise-free truth (the limit sigma sqrt(p/M)
is 13.4 um). FIGAROH is driven through `BaseCalibration` (unified YAML config: base_frame universe,
tool_frame tool0, one marker with x/y/z measurable, `calibration_level` and `estimation.method` as in the
row), with a subclass that sets `known_baseframe`/`known_tipframe` False (the unified config does not set
them; the device frame and the marker are unknown, as in our problem) and a cost function of plain
position residuals in the device frame; the ur5 URDF is example-robot-data's, the one our catalogue loads.

- With its default selection (`structural`) FIGAROH estimates 25 parameters, 2 short of the 27 that the
  data identify: the fit stops at 0.34 mm RMS and 0.39 mm against the truth, 30 times the noise limit.
  The shoulder_lift zero (`d_phiy_shoulder_lift_joint`) is not in its set, for example.
- With `estimation.method: excitation` (or `cv_subset`) it estimates the same 27 and its held-out
  predictions coincide with ours to 0.01 um: 33.3 / 38.0 / 11.9 um, the same numbers. `map` and `map_cv`
  estimate all 45 with Gaussian priors and land on the same predictions (within 0.1 um).
- `joint_offset` (zeros only, 13 parameters) cannot represent the planted origin errors: 4 mm.
- Time: ours is one `calibrate` call (registration, identification, fits, statistics, calibrated URDF),
  median of 5 after a warm-up; FIGAROH's is one construction + `initialize` + `solve` (config and CSV
  read, parameter selection, LM, its statistics and quality report), median of 3. The cross-validated
  methods refit per fold and candidate, hence 7-8 s.
"""


def figaroh(path: str, out: str) -> None:
    import contextlib
    import io
    import os
    import platform
    import tempfile
    from datetime import datetime, timezone

    import pinocchio as pin
    from figaroh.calibration.base_calibration import BaseCalibration
    from figaroh.calibration.calibration_tools import calc_updated_fkm

    d = np.load(path)
    Q, P, tp, fit, held = d["Q"], d["measured"], d["truth_positions"], d["fit"], d["held"]
    names = [str(n) for n in d["joint_names"]]
    # the ur5 URDF of example-robot-data (pip package example-robot-data, the one our catalogue loads)
    share = os.path.join(os.path.dirname(pin.__file__).split("cmeel.prefix")[0], "cmeel.prefix", "share")
    urdf = os.path.join(share, "example-robot-data", "robots", "ur_description", "urdf", "ur5_robot.urdf")
    robot = pin.RobotWrapper.BuildFromURDF(urdf, [share])
    model = robot.model
    assert [model.names[i] for i in range(1, model.njoints)] == names, list(model.names)

    class UR5Calibration(BaseCalibration):
        def load_param(self, config_file, setting_type="calibration"):
            super().load_param(config_file, setting_type)
            self.calib_config["known_baseframe"] = False  # the device frame is unknown
            self.calib_config["known_tipframe"] = False   # so is the marker on the flange

        def cost_function(self, var):
            PEEe = calc_updated_fkm(self.model, self.data, var, self.q_measured, self.calib_config)
            return self.PEE_measured - PEEe

    rows = []
    tmp = tempfile.mkdtemp()
    _csv(f"{tmp}/fit.csv", names, Q[fit], P[fit])
    _csv(f"{tmp}/val.csv", names, Q[held], P[held])
    runs = [("full_params", m) for m in ("structural", "excitation", "map", "map_cv", "cv_subset")]
    runs.append(("joint_offset", "structural"))
    for level, method in runs:
        cfg = f"{tmp}/ur5_{level}_{method}.yaml"
        with open(cfg, "w") as f:
            f.write(CONFIG.format(level=level, method=method, data=f"{tmp}/fit.csv", val=f"{tmp}/val.csv"))
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            calib = UR5Calibration(robot, cfg)
            calib.initialize()
            with contextlib.redirect_stdout(io.StringIO()):  # its quality report
                calib.solve(enable_logging=False)
            times.append(time.perf_counter() - t0)
        var = calib.LM_result.x
        n = len(calib.calib_config["param_name"])
        def predict(q):
            c = dict(calib.calib_config, NbSample=len(q))
            return calc_updated_fkm(model, robot.data, var, q, c).reshape(3, -1).T

        pred, pred_fit = predict(Q[held]), predict(Q[fit])
        r = calib.LM_result
        print(level, method, "success", r.success, r.status, r.nfev, r.message, "cost", r.cost)
        same = float(np.max(np.linalg.norm(pred - d["ours_pred"][held], axis=1)))
        rows.append([f"FIGAROH ({level}, {method})", n,
                     _rms(pred_fit - P[fit]), _rms(pred - P[held]), _rms(pred - tp[held]), float(np.median(times)),
                     f"{same * 1e6:.2f}"])
        print(level, method, n, calib.calib_config["param_name"])
    ours = d["ours_pred"]
    rows.insert(0, ["ours (calibrate, complete-and-minimal)", int(d["ours_rank"]), float(d["ours_rmse_after"]),
                    _rms(ours[held] - P[held]), _rms(ours[held] - tp[held]), float(d["ours_time"]), "-"])
    lines = ["| method | estimated parameters | RMS after, 60 fitted (um) | held-out RMS, 40 (um) | "
             "held-out vs truth (um) | time (ms) | max distance to our prediction, held-out (um) |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r[0]} | {r[1]} | {r[2] * 1e6:.1f} | {r[3] * 1e6:.1f} | {r[4] * 1e6:.1f} | "
                     f"{r[5] * 1e3:.0f} | {r[6]} |")
    head = [
        "# FIGAROH side by side (ur5, positions, same data)", "",
        "Commands (from the worktree; the second runs in a separate venv with `pip install figaroh example-robot-data`; figaroh 1.0.2 does not pull the latter):", "",
        "    PYTHONPATH=$PWD .venv/bin/python bench/figaroh_side_by_side.py export /tmp/ur5_cal_data.npz",
        "    /tmp/figvenv/bin/python bench/figaroh_side_by_side.py figaroh /tmp/ur5_cal_data.npz bench/RESULTS_FIGAROH.md",
        "",
        f"Run {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, Python {platform.python_version()}, "
        f"figaroh {_version('figaroh')}, pin {_version('pin')}, example-robot-data {_version('example-robot-data')} "
        f"(load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}).", "",
    ]
    text = "\n".join(head + lines + ["", NOTES])
    print(text)
    with open(out, "w") as f:
        f.write(text + "\n")


if __name__ == "__main__":
    {"export": export, "figaroh": figaroh}[sys.argv[1]](*sys.argv[2:])
