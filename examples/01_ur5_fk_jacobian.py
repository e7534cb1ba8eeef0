"""UR5: forward kinematics and Jacobians of the tool, checked against Pinocchio.

Run: python examples/01_ur5_fk_jacobian.py
"""

import numpy as np

import kinematics

ur5 = kinematics.default_catalogue().get("ur5")
print("joints:", ", ".join(ur5.joint_names))

# one configuration, in model.joint_names order (a {joint: value} map works too)
q = [0.0, -1.5708, 1.5708, 0.0, 1.5708, 0.0]
fk = kinematics.fk(ur5, q, links=["tool0"], verify=True)
T = fk.poses[0, 0]  # T_world_tool0, (4, 4)
print("tool0 position (m):", np.round(T[:3, 3], 6))
print("tool0 quaternion (w, x, y, z):", np.round(fk.components()["quaternion"][0, 0], 6))
print(f"FK deviation from Pinocchio: {fk.verification.max_position_error:.1e} m")

# --8<-- [start:jacobians]
# the three Jacobian references, 6 x 6, linear rows first
for reference in ("world", "local", "local_world_aligned"):
    jac = kinematics.jacobian(ur5, q, link="tool0", reference=reference, verify=True)
    err = jac.verification.max_jacobian_error
    print(f"J[{reference}] row 0: {np.round(jac.jacobians[0, 0], 4)}  (vs Pinocchio {err:.1e})")

# a batch: 1,000 random configurations within the limits, compiled kernels, no Python loop
Q = ur5.sample_configurations(1000, np.random.default_rng(0))
jac = kinematics.jacobian(ur5, Q, link="tool0", reference="local_world_aligned")
manipulability = jac.conditioning()["manipulability"]
print(f"batch: {jac.jacobians.shape}, manipulability {manipulability.min():.4f} .. {manipulability.max():.4f}")

# J(q) qdot is the tool's velocity: compare with a finite difference of FK
qdot = np.array([0.5, 0.0, 0.0, 0.0, 0.0, 0.2])
h = 1e-6
p0 = kinematics.fk(ur5, q, links=["tool0"]).poses[0, 0, :3, 3]
p1 = kinematics.fk(ur5, np.add(q, h * qdot), links=["tool0"]).poses[0, 0, :3, 3]
J = kinematics.jacobian(ur5, q, link="tool0", reference="local_world_aligned").jacobians[0]
print("finite difference agrees:", bool(np.allclose((p1 - p0) / h, J[:3] @ qdot, atol=1e-5)))
# --8<-- [end:jacobians]
