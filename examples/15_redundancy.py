"""Every solution of a 7-joint arm: a Panda's self-motion sliced at values of q7, the q7 ranges
over which it stays within its limits, and its best point for the limit margin.

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
