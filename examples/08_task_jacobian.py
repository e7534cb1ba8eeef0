"""Task vectors r = (p, phi) and analytic Jacobians J_r = dr/dq, against finite differences.

The orientation phi is given as Euler angles (rpy, zyx, zyz), a quaternion, a rotation vector,
or the subsets position, scara (px, py, pz, alpha_z) and planar (px, py, phi).

Run: python examples/08_task_jacobian.py
"""

import numpy as np

import kinematics
from kinematics import api

catalogue = kinematics.default_catalogue()
ur5 = catalogue.get("ur5")
q = np.array([0.0, -1.2, 1.5, -0.4, 1.1, 0.3])

for representation in ("rpy", "zyz", "quaternion", "rotvec"):
    ans = api.task(ur5, q, link="tool0", representation=representation)
    r, J_r = ans.r[0], ans.J_r[0]
    # central differences of r(q), one joint at a time
    h = 1e-6
    numeric = np.empty_like(J_r)
    for j in range(6):
        step = np.zeros(6)
        step[j] = h
        numeric[:, j] = (api.task(ur5, q + step, link="tool0", representation=representation).r[0]
                         - api.task(ur5, q - step, link="tool0", representation=representation).r[0]) / (2 * h)
    print(f"{representation:10s} r = {np.round(r, 4)}, J_r {J_r.shape}, "
          f"vs finite differences {np.abs(J_r - numeric).max():.1e}")

# a planar arm: r = (px, py, phi) with phi = q1 + q2
arm = catalogue.get("planar_2r")
ans = api.task(arm, [0.0, np.pi / 2], representation="planar")
print("planar 2R: r =", np.round(ans.r[0], 6), "J_r =", np.round(ans.J_r[0], 6).tolist())

# the same analytic Jacobian, its rows picked by name, and its conditioning
ans = api.task(ur5, q, link="tool0", representation="rpy", components=["px", "py", "pz", "yaw"])
print("rows", ans.representation.components, "manipulability", round(float(ans.conditioning()["manipulability"][0]), 6))

# where E(phi) is singular the answer is a refusal naming the configuration: ZYZ angles of a
# rotation about z alone (theta = 0, the gimbal lock of ZYZ), as every pose of a planar arm is
try:
    api.task(arm, [[0.1, 0.2], [0.3, 0.2]], representation="zyz")
except kinematics.KinematicsError as error:
    print("refused:", type(error).__name__, "-", error)
