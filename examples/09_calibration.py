"""Kinematic calibration: where to measure, the fit, and a calibrated model that predicts the arm.

The "real" UR5 here is a synthetic one (1 mm / 1 mrad off on every joint origin, 10 mrad on
every zero, a measuring device somewhere in the room), measured with 20 um noise; with a real
arm the positions come from the tracker. Run: python examples/09_calibration.py
"""

import numpy as np

import kinematics
from kinematics import usecases
from kinematics.algorithms.calibration.synthetic import plant

ur5 = kinematics.default_catalogue().get("ur5")
query = kinematics.Query(ur5, link="tool0", point=[0.05, 0.03, 0.1])  # the marker, roughly

# where to drive the arm: 30 configurations that determine the parameters best (D-optimal)
choice = usecases.calibration_poses(query, 30)
print(f"chosen poses: log det {choice.log_det:.1f} (random {choice.random_log_det:.1f})")

truth = plant(ur5, "tool0", "position", np.random.default_rng(0))
Q = choice.q
measured = truth.measure(Q, sigma=20e-6)  # what the tracker saw, in its own frame

cal = usecases.calibrate(query, [{"q": q.tolist(), "position": p.tolist()} for q, p in zip(Q, measured)],
                         loss="huber")
print(f"identifiable: {cal.identifiable} (4R + 3 = 27); unidentifiable: {len(cal.unidentifiable)}, e.g.",
      cal.unidentifiable[0])
print(f"RMS before {cal.rmse_before * 1e3:.2f} mm, after {cal.rmse_after * 1e6:.1f} um")
for p in cal.parameters:
    if p["name"].endswith(".offset"):
        print(f"  {p['name']:<28} {p['value'] * 1e3:8.3f} mrad +- {p['sigma'] * 1e3:.3f}")

# the calibrated model is an ordinary model: its FK, with the estimated base and point,
# predicts the device's view of configurations it was not fitted on
fresh = ur5.sample_configurations(100, np.random.default_rng(1))
answer = kinematics.fk(cal.model, fresh, links=["tool0"], base=cal.base.tolist(), point=cal.point.tolist())
error = np.linalg.norm(answer.poses[:, 0, :3, 3] - truth.predict(fresh)[:, :3, 3], axis=1)
nominal = kinematics.fk(ur5, fresh, links=["tool0"], base=cal.base.tolist(), point=cal.point.tolist())
error0 = np.linalg.norm(nominal.poses[:, 0, :3, 3] - truth.predict(fresh)[:, :3, 3], axis=1)
print(f"new configurations: nominal model {error0.mean() * 1e3:.2f} mm off, calibrated {error.mean() * 1e6:.1f} um off")
print("calibrated URDF:", len(cal.urdf), "characters, robot", cal.model.name)
