"""Calibration on real data: FIGAROH's TIAGo motion-capture sessions, joint compliance and tolerances.

Fitted on one session (37 static postures, the marker BL of the hand), judged on three others
taken on other days, as FIGAROH's own held-out protocol does. The arm's joints give under the
arm's weight: Compliance() adds c_j times each joint's gravity torque (from the URDF's masses);
Prior() says the joints were built within about 1 cm and 20 mrad. Run:
python examples/17_calibration_compliance.py
"""

from pathlib import Path

import numpy as np

import kinematics
from kinematics import usecases
from kinematics.algorithms.calibration import Compliance, Prior

DATA = Path(__file__).resolve().parents[1] / "tests" / "fixtures" / "figaroh" / "tiago_mocap"
SESSIONS = ["2021-11-30", "2021-11-26", "2021-11-30-1403", "2021-11-30-1504"]  # training first
JOINTS = ["torso_lift_joint"] + [f"arm_{i}_joint" for i in range(1, 8)]
tiago = kinematics.default_catalogue().get("tiago")


def session(name):
    """The joint values (N, dof; the head, wheels and hand at 0) and the BL marker's positions (m)."""
    table = np.genfromtxt(DATA / f"qualisys_{name}_static_postures.csv", delimiter=",", names=True)
    Q = np.zeros((len(table), tiago.dof))
    for j in JOINTS:
        Q[:, tiago.q_index[j]] = table[j]
    return Q, np.column_stack([table["x1"], table["y1"], table["z1"]])


Q, bl = session(SESSIONS[0])
query = kinematics.Query(tiago, link="wrist_ft_tool_link")
measured = [{"q": q.tolist(), "position": p.tolist()} for q, p in zip(Q, bl)]
plain = usecases.calibrate(query, measured)
cal = usecases.calibrate(query, measured, compliance=Compliance(), prior=Prior())
print(f"identifiable: {cal.identifiable}; training RMS {plain.rmse_after * 1e3:.2f} mm plain, "
      f"{cal.rmse_after * 1e3:.2f} mm with compliance and prior")
for p in cal.parameters:
    if p["name"] in ("arm_2_joint.compliance", "arm_4_joint.compliance"):
        print(f"  {p['name']:<24} {p['value'] * 1e3:6.2f} +- {p['sigma'] * 1e3:.2f} mrad/(N m)")

figaroh = [3.07, 2.83, 2.44]  # its published full_params held-out RMS, mm
for name, theirs in zip(SESSIONS[1:], figaroh):
    Q, bl = session(name)
    errors = [np.linalg.norm(c.predict(Q)[:, :3, 3] - bl, axis=1) for c in (plain, cal)]
    rms = [np.sqrt(np.mean(e ** 2)) * 1e3 for e in errors]
    print(f"held out {name}: plain {rms[0]:.2f} mm, compliance + prior {rms[1]:.2f} mm (FIGAROH {theirs:.2f})")
