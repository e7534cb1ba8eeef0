"""Every IK solution: a UR5's eight arm postures, a Panda with its last joint locked, and a
Cartesian path that stays on one branch.

Run: python examples/10_ik_all.py
"""

import numpy as np

import kinematics
from kinematics import api

catalogue = kinematics.default_catalogue()
ur5 = catalogue.get("ur5")
q = np.array([0.3, -1.0, 1.2, -0.5, 0.8, 0.2])
target = kinematics.fk(ur5, q, links=["tool0"]).poses[0, 0]

# the family of the chain, read from the model's own screws
print("ur5 family:", api.ik_family(ur5, link="tool0")["family"])

# each branch once (angles in (-pi, pi]), nearest the seed first, checked against Pinocchio
every = api.ik(ur5, target, link="tool0", solutions="all", limits="ignore", seed=q, verify=True)
print(f"{int(every.count[0])} solutions ({every.method}); first = seed: {np.allclose(every.q[0, 0], q)}")
print(f"worst Pinocchio deviation: {every.verification['max_position_error']:.1e} m")
for s in every.solutions(0)[:3]:
    print("  q =", np.round(s["q"], 3), "singular" if s["singular"] else "")

# inside the limits with every 2 pi copy of UR's +-2 pi joints
inside = api.ik(ur5, target, link="tool0", solutions="all")
print("within the limits, copies included:", int(inside.count[0]))

# a 7-dof arm with one joint locked is a 6-joint chain with a closed form
panda = catalogue.get("panda")
qp = np.array([0.1, -0.4, 0.2, -2.0, 0.3, 1.5, 0.7, 0.02])
Tp = kinematics.fk(panda, qp, links=["panda_link8"]).poses[0, 0]
locked = api.ik(panda, Tp, link="panda_link8", solutions="all", locked={"panda_joint7": 0.7}, limits="ignore")
print(f"panda, q7 locked: {locked.family}, {int(locked.count[0])} solutions")

# unreachable: no solution, and nothing claimed
far = np.eye(4); far[:3, 3] = [3.0, 0.0, 0.0]
print("3 m away:", int(api.ik(ur5, far, link="tool0", solutions="all").count[0]), "solutions")

# a straight line of 10 cm, solved by continuation: never a jump of more than 0.2 rad
end = target.copy(); end[:3, 3] += [0.1, 0.0, 0.0]
path = api.ik_path(ur5, np.array([target, end]), link="tool0", seed=q, step={"position": 0.01}, max_joint_step=0.2)
print(f"path: {len(path.q)} rows, complete {path.complete}, largest joint step {path.max_joint_step:.3f} rad")
