"""Collision pairs a user sets: allow a pair (a gripper holding a tool), forbid one the sampling
called "never" (checked all the same), see them in the matrix and its SRDF; and a pair MoveIt's
own UR5 SRDF disables as "never" colliding within the limits, by us and by Pinocchio with coal.

Run: python examples/14_collision_pairs.py
"""

import numpy as np

import kinematics
from kinematics import UserPairs
from kinematics.io.catalogue import example_robot_data_dir
from kinematics.verify.pinocchio import compare_collision

ur5 = kinematics.default_catalogue().get("ur5")

# MoveIt's ur5.srdf disables (base_link_inertia = our base_link, upper_arm_link) as "Never";
# here the upper arm is swung down through the base, within the joint limits
q = [-3.58, 1.75, 1.92, 5.83, -4.39, -0.22]
pair = ("base_link", "upper_arm_link")
plain = kinematics.collision(ur5, [q], samples=2000)
print("colliding pairs:", plain.pairs[0][:1], "...", len(plain.pairs[0]), "in all")
pin = compare_collision(ur5, np.array([q]), [pair], [example_robot_data_dir().parent.parent], [[pair]])
print("Pinocchio with coal agrees the pair collides:", pin.same_pairs == 1)

# a user's pairs: allow one (never checked, reason "user"), forbid one the matrix disables
pairs = UserPairs(allow=[("upper_arm_link", "base_link")], forbid=[("wrist_1_link", "ee_link")])
answer = kinematics.collision(ur5, [q], samples=2000, collision_pairs=pairs)
print("with the pairs, still in collision:", pair in answer.pairs[0], "| pairs checked:", len(plain.checked), "->",
      len(answer.checked), "(one allowed, one forbidden)")

matrix = kinematics.collision_matrix(ur5, 2000, collision_pairs=pairs)
print("reason:", matrix.disabled[pair], "| forced:", matrix.forced)
srdf = matrix.to_srdf("ur5").splitlines()
print(*[line.strip() for line in srdf if "User" in line], sep="\n")

# the same pairs as a model's setting in the service (PUT /models/ur5/collision/pairs),
# a request (allow / forbid of POST /models/ur5/collision) or the CLI:
#   kinematics collision --model ur5 q.csv --allow base_link,upper_arm_link --forbid wrist_1_link,ee_link
