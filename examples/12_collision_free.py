"""Collision-free answers on the UR5's catalogue meshes: every IK solution that does not run the
arm into itself, a numerical answer that searches on until it is free, a Cartesian path that
stops where the arm would hit itself, and the workspace of the free configurations only.

Run: python examples/12_collision_free.py
"""

import numpy as np

import kinematics
from kinematics import usecases
from kinematics.io.catalogue import example_robot_data_dir
from kinematics.verify.pinocchio import PinocchioCollision

ur5 = kinematics.default_catalogue().get("ur5")
fk = kinematics.compile_model(ur5)
SAMPLES = 2000  # random configurations behind the allowed-collision matrix (the service: 10,000)

# a pose reached with the elbow shut (the wrist in the upper arm): half of its solutions collide
q = np.array([0.7, -0.7, 3.0, 2.9, 1.1, 0.9])
target = fk.fk(q[None], ["tool0"])[0, 0]
every = usecases.ik(ur5, target, link="tool0", solutions="all", limits="ignore")
free = usecases.ik(ur5, target, link="tool0", solutions="all", limits="ignore", avoid_collisions=True,
                   collision_samples=SAMPLES)
print(f"solutions: {int(every.count[0])}, free of self-collision: {int(free.count[0])} "
      f"({int(free.colliding[0])} left out)")

# Pinocchio with coal on the same geometry and pairs agrees: the listed ones are free
pairs = usecases.collision_matrix(ur5, SAMPLES).enabled()
pc = PinocchioCollision(ur5, pairs, [example_robot_data_dir().parent.parent])
print("Pinocchio finds the listed ones free:", all(pc.collisions(s) == [] for s in free.q[0, :free.count[0]]))

# one numerical answer seeded at q: it converges to q, which collides; with the option it searches on
plain = usecases.ik(ur5, target, link="tool0", seed=q)
print("plain answer free:", bool(usecases.collision_free(ur5, plain.solution.q, samples=SAMPLES)[0]))
one = usecases.ik(ur5, target, link="tool0", seed=q, avoid_collisions=True, collision_samples=SAMPLES)
print("with avoid_collisions: success", bool(one.solution.success[0]), "free", bool(one.collision_free[0]))

# a straight line that closes the elbow until the wrist enters the upper arm
q0, q1 = [0, -1.0, 1.5, 0, 0, 0], [0, -1.0, 2.9, 0, 0, 0]
W = fk.fk(np.array([q0, q1], dtype=float), ["tool0"])[:, 0]
path = usecases.ik_path(ur5, W, link="tool0", seed=q0, avoid_collisions=True, collision_samples=SAMPLES)
print(f"path: {len(path.q)} of {len(path.targets)} rows, stopped {path.stopped}, fraction {path.fraction:.2f}")

# the workspace of the collision-free samples only
ws = usecases.workspace(ur5, "tool0", samples=5000, collision_free=True, collision_samples=SAMPLES)
print(f"workspace: {ws.samples} free samples kept, {ws.dropped} in self-collision dropped")
