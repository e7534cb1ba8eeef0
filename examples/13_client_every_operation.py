"""Every operation of the service from Python, numpy in and out: ``kinematics.client`` beyond FK.

Start a service first (``make serve``); the example talks to ``KIN_BASE_URL`` (default
http://127.0.0.1:8000). Run: KIN_BASE_URL=http://127.0.0.1:8000 python examples/13_client_every_operation.py
"""

import os

import numpy as np

from kinematics.client import Client

kin = Client(os.environ.get("KIN_BASE_URL", "http://127.0.0.1:8000"), api_key=os.environ.get("KIN_API_KEY"))
q0 = np.array([0.1, -1.2, 1.4, -1.6, -1.5, 0.2])
T0 = kin.fk("ur5", q0, links=["tool0"])[0, 0]

# every IK solution (.npz), and the chain's family
every = kin.ik_all("ur5", T0, link="tool0")
print("family:", kin.ik_family("ur5", link="tool0")["family"], "solutions:", int(every["count"][0]))

# a straight line of 10 cm, solved by continuation from q0
T1 = T0.copy()
T1[:3, 3] += [0.0, 0.1, 0.0]
path = kin.ik_path("ur5", np.stack([T0, T1]), link="tool0", seed=q0, step={"position": 0.01})
print("path:", path["q"].shape, "complete:", path["complete"])

# calibration: where to measure, then a fit of what a (here: simulated) device saw
poses = kin.calibration_poses("ur5", 30, link="tool0", random_seed=0)
marker = kin.fk("ur5", poses["q"], links=["tool0"], point=[0.05, 0.05, 0.05])[:, 0, :3, 3]
seen = marker + [0.001, -0.002, 0.0005]  # the device's frame is 2 mm off the robot's
fit = kin.calibrate("ur5", [{"q": q, "position": p} for q, p in zip(poses["q"], seen)], link="tool0")
print(f"calibrated: {fit['model'][:2]}... rmse {fit['rmse_after']:.1e} m")

# self-collision of a batch with distances, and the allowed-collision matrix
Q = np.array([[0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8, 0.02], [0.0, 0.0, 0.0, -1.5, 0.0, 1.5, 0.8, 0.02]])
hit = kin.collision("panda", Q, distance=True)
print("panda colliding:", hit["colliding"], "pairs checked:", hit["checked_pairs"])
print("never checked:", len(kin.collision_matrix("panda")["disabled"]), "pairs")

# workspace: the summary, and the cloud as arrays
ws = kin.workspace("planar_2r", samples=20_000, voxel=0.05)
cloud = kin.workspace("planar_2r", samples=20_000, voxel=0.05, cloud=True)
print(f"workspace: area {ws['area']:.3f} m^2 converged {ws['converged']} cloud {cloud['points'].shape}")

# closed forms and task vectors
forms = kin.symbolic("planar_2r", what=["transforms"], format="text")
print("T(q) of planar_2r, x:", forms["T"][0][3])
task = kin.task("ur5", q0, link="tool0", representation="zyz")
print("task:", task["components"], task["J_r"].shape)
