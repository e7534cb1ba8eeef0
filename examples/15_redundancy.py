"""Every solution of a 7-joint arm: a Panda's self-motion sliced at values of q7, the q7 ranges
over which it stays within its limits, its best point for the limit margin, and a Cartesian path
that jumps with q7 locked and not along the self-motion.

Run: python examples/15_redundancy.py
"""

import numpy as np

import kinematics
from kinematics import api

panda = kinematics.default_catalogue().get("panda")
q = np.array([0.3, -0.5, 0.2, -2.0, 0.4, 1.8, 0.7, 0.0])
target = kinematics.fk(panda, q, links=["panda_link8"]).poses[0, 0]

# which joint runs along the self-motion with a closed form when locked
family = api.ik_family(panda, link="panda_link8")
print("redundant:", family["redundant"], "default parameter:", family["default_parameter"])

# every solution at three values of q7, each with its parameter value
sliced = api.ik(panda, target, link="panda_link8", solutions="all",
                redundancy={"values": [0.0, 0.7, 1.4]})
print(f"{int(sliced.count[0])} solutions at q7 in {{0, 0.7, 1.4}}")
print("generating configuration listed:",
      bool(np.abs(sliced.q[0, :sliced.count[0], :7] - q[:7]).max(axis=1).min() < 1e-9))
print(f"worst error: {np.nanmax(sliced.position_error):.1e} m")

# the whole self-motion: the in-limit q7 ranges and the best point for the limit margin
best = api.ik(panda, target, link="panda_link8", solutions="all",
              redundancy={"intervals": True, "select": "margin"})
for r in best.intervals[0]:
    print(f"  q7 in [{r['from']:.6f}, {r['to']:.6f}] on {len(r['branches'])} branch pieces")
print(f"best margin at q7 = {best.parameter[0, 0]:.6f}:", np.round(best.q[0, 0, :7], 3))

# a straight line on which q2 passes zero (the axes of q1 and q3 line up): with q7 locked the
# six-joint chain is singular there and the path stops; along the self-motion it goes through
start = np.array([-1.0, -0.1, 0.64, -2.41, -0.48, 0.9, 0.66, 0.0])
a = kinematics.fk(panda, start, links=["panda_link8"]).poses[0, 0]
b = a.copy()
b[:3, 3] += [0.0, -0.08, -0.025]
locked = api.ik_path(panda, np.array([a, b]), link="panda_link8", seed=start, locked={"panda_joint7": 0.66})
print("q7 locked:", locked.stopped, f"fraction {locked.fraction:.2f}")
moving = api.ik_path(panda, np.array([a, b]), link="panda_link8", seed=start, redundancy={"select": "nearest"})
print(f"self-motion: complete {moving.complete}, largest joint step {moving.max_joint_step:.3f} rad, "
      f"q7 from {moving.q[0, 6]:.3f} to {moving.q[-1, 6]:.3f}, worst error {moving.position_error.max():.1e} m")
