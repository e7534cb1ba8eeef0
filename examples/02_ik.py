"""Inverse kinematics: UR5 tool poses solved back to joint values, and a Panda reaching positions.

Run: python examples/02_ik.py
"""

import numpy as np

import kinematics
from kinematics import api

catalogue = kinematics.default_catalogue()
ur5 = catalogue.get("ur5")

# one target pose T_world_tool0 in any pose form: here position + roll-pitch-yaw
target = {"xyz": [0.4, 0.1, 0.3], "rpy": [3.14159, 0.0, 0.0]}
answer = api.ik(ur5, target, link="tool0", verify=True)
sol = answer.solution
print("q:", np.round(sol.q[0], 4))
print(f"success {bool(sol.success[0])}: position error {sol.position_error[0]:.1e} m, "
      f"rotation error {sol.rotation_error[0]:.1e} rad, {int(sol.iterations[0])} iterations")
print(f"Pinocchio's FK of the answer is {answer.verification['position_error'][0]:.1e} m off the target")

# a batch: poses of 200 random configurations, solved from the default seed with restarts
Q = ur5.sample_configurations(200, np.random.default_rng(1))
T = kinematics.fk(ur5, Q, links=["tool0"]).poses[:, 0]  # (200, 4, 4)
batch = api.ik(ur5, T, link="tool0", random_seed=0).solution
print(f"batch: solved {int(batch.success.sum())}/{len(T)}, worst position error "
      f"{batch.position_error[batch.success].max():.1e} m")

# every answer claiming success puts tool0 on its target (FK of the answers)
T_back = kinematics.fk(ur5, batch.q, links=["tool0"]).poses[:, 0]
off = np.linalg.norm(T_back[:, :3, 3] - T[:, :3, 3], axis=1)
print("successful answers on target:", bool((off[batch.success] < 1e-6).all()))

# position-only IK of a 7-joint arm; an unreachable target answers the best effort, success False
panda = catalogue.get("panda")
reach = api.ik(panda, [{"xyz": [0.5, 0.2, 0.4], "rpy": [0, 0, 0]}, {"xyz": [3.0, 0.0, 0.0], "rpy": [0, 0, 0]}],
               link="panda_link8", mode="position").solution
for label, ok, err in zip(("reachable", "3 m away"), reach.success, reach.position_error):
    print(f"panda {label}: success {bool(ok)}, position error {err:.3g} m")
