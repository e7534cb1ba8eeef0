"""Self-collision of the UR5 and the Panda on their catalogue meshes: a batch check with
distances, the allowed-collision matrix as SRDF, and the same answer from Pinocchio with coal.

Run: python examples/11_self_collision.py
"""

import numpy as np

import kinematics
from kinematics import usecases
from kinematics.io.catalogue import example_robot_data_dir
from kinematics.verify.pinocchio import compare_collision

catalogue = kinematics.default_catalogue()
ur5 = catalogue.get("ur5")

# two configurations: a ready pose, and the elbow shut so that the wrist enters the upper arm
ready, folded = [0, -1.57, 0, -1.57, 0, 0], [0, -1.0, 2.9, 0, 0, 0]
answer = usecases.collision(ur5, [ready, folded], distance=True, samples=2000)
print("colliding:", answer.colliding.tolist())
print("pairs in collision (folded):", answer.pairs[1][:2], "...")
print(f"ready: {answer.min_distance[0] * 1000:.1f} mm between {answer.closest[0]}")
print(f"checked {len(answer.checked)} of {len(answer.links) * (len(answer.links) - 1) // 2} pairs")

# the allowed-collision matrix: the pairs never checked, each with its reason (MoveIt's SRDF)
panda = catalogue.get("panda")
matrix = usecases.collision_matrix(panda, 2000)
reasons = sorted(set(matrix.disabled.values()))
print("panda:", len(matrix.disabled), "pairs disabled;", {r: list(matrix.disabled.values()).count(r) for r in reasons})
print(matrix.to_srdf("panda").splitlines()[2])

# a batch, and Pinocchio's computeCollisions on the same geometry and pairs
Q = panda.sample_configurations(500, np.random.default_rng(0))
ours = usecases.collision(panda, Q, distance=True, samples=2000)
agreement = compare_collision(panda, Q, ours.checked, [example_robot_data_dir().parent.parent], ours.pairs,
                              distances=ours.min_distance)
print(f"{int(ours.colliding.sum())} of 500 in collision; same pairs as Pinocchio: {100 * agreement.fraction:.1f}%")
print(f"distance deviation from Pinocchio: {agreement.max_distance_error:.1e}")

# the library function other features call (collision-free IK answers, workspace samples)
free = usecases.collision_free(panda, Q, samples=2000)
print("collision-free:", int(free.sum()), "of", len(free))
