"""A floating-base robot: ANYmal C's feet for a base pose, their Jacobians and velocities.

With ``floating_base=True`` the model sits on a free-flyer ``root_joint`` (as Pinocchio's
``JointModelFreeFlyer``): q is ``x, y, z, qx, qy, qz, qw`` of the base (a unit quaternion) and
then the 12 leg joints; velocities and Jacobian columns are ``6 + 12`` (the base twist first).

Run: python examples/03_floating_base.py
"""

import numpy as np

import kinematics
from kinematics import api

anymal = kinematics.default_catalogue().get("anymal_c")  # its URDF has no root joint: 12 leg joints
feet = ["LF_FOOT", "RF_FOOT", "LH_FOOT", "RH_FOOT"]

# the base 0.5 m up, turned 90 degrees about z; legs at a standing posture
half = np.pi / 4
base = [0.0, 0.0, 0.5, 0.0, 0.0, np.sin(half), np.cos(half)]
legs = [0.0, 0.6, -1.2] * 2 + [0.0, -0.6, 1.2] * 2
q = base + legs
fk = kinematics.fk(anymal, q, links=feet, floating_base=True, verify=True)
floating = fk.model  # the model on its free-flyer root joint
print(f"nq = {floating.nq}, nv = {floating.nv}; q starts", floating.q_labels[:8])
for name, T in zip(fk.links, fk.poses[0]):
    print(f"{name}: {np.round(T[:3, 3], 4)}")
print(f"FK deviation from Pinocchio: {fk.verification.max_position_error:.1e} m")

# the same feet with the base at the origin, rotated back: the base pose is a rigid motion
q0 = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0] + legs
T0 = kinematics.fk(anymal, q0, links=feet, floating_base=True).poses[0]
B = np.eye(4)
B[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
B[:3, 3] = [0, 0, 0.5]
print("base pose moves every foot rigidly:", bool(np.allclose(B @ T0, fk.poses[0], atol=1e-12)))

# the Jacobian of one foot: 6 x 18, the first 6 columns the base twist (its own frame)
jac = kinematics.jacobian(anymal, q, link="LF_FOOT", reference="local_world_aligned",
                          floating_base=True, verify=True)
print(f"J shape {jac.jacobians.shape[1:]}, vs Pinocchio {jac.verification.max_jacobian_error:.1e}")

# a base moving up at 0.2 m/s and legs at rest: every foot moves up at 0.2 m/s
v = np.zeros(floating.nv)
v[2] = 0.2  # the base twist is in the base frame; z is up for this base
vel = api.velocity(anymal, q, v, links=feet, floating_base=True, verify=True)
print("foot velocities (m/s):", np.round(vel.linear[0], 6).tolist())
print(f"velocities vs Pinocchio {vel.verification.max_velocity_error:.1e}")

# a quaternion that is not unit length is refused, naming the joint, unless normalize=True
try:
    kinematics.fk(anymal, [0, 0, 0.5, 0, 0, 0, 2.0] + legs, floating_base=True)
except kinematics.JointValueError as error:
    print("refused:", error)
print("normalized:", np.round(kinematics.fk(anymal, [0, 0, 0.5, 0, 0, 0, 2.0] + legs, links=["LF_FOOT"],
                                            floating_base=True, normalize=True).poses[0, 0, :3, 3], 4))
