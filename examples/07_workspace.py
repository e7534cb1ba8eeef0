"""Workspaces by sampling: a planar 2R arm's area against its exact annulus, and the UR5's reach,
volume and dexterity.

Run: python examples/07_workspace.py
"""

import numpy as np

import kinematics
from kinematics import api

catalogue = kinematics.default_catalogue()

# a planar 2R arm (l1 = 0.5 m, l2 = 0.4 m) reaches the annulus between 0.1 m and 0.9 m
arm = catalogue.get("planar_2r")
ws = api.workspace(arm, "tool", samples=100_000, random_seed=0, measure="position")
exact = np.pi * (0.9 ** 2 - 0.1 ** 2)
print(f"planar 2R: dimension {ws.dimension}, reach {ws.reach:.4f} m")
print(f"area {ws.area:.4f} m^2, exact {exact:.4f} m^2 ({100 * abs(ws.area / exact - 1):.2f}% off)")
print("convergence (samples, area):", [(n, round(a, 4)) for n, a in ws.convergence])
# position manipulability of a 2R arm is l1 l2 |sin q2|: at most 0.2, zero when stretched or folded
print(f"manipulability {ws.manipulability.min():.4f} .. {ws.manipulability.max():.4f} (at most 0.2)")

# the UR5's tool: reach, volume with its convergence, and the dexterity map's cells
ur5 = catalogue.get("ur5")
ws = api.workspace(ur5, "tool0", samples=200_000, random_seed=7)
low, high = ws.bounding_box
print(f"ur5: reach {ws.reach:.3f} m, box {np.round(low, 2)} .. {np.round(high, 2)}")
print("volume (m^3) over N/4, N/2, N samples:", [round(v, 3) for _, v in ws.convergence])
print(f"dexterity map: {len(ws.voxel_centers)} cells of edge {ws.voxel:.3f} m")

# every sample is a real pose: FK of the same configurations reaches at most `reach`
Q = ur5.sample_configurations(10_000, np.random.default_rng(7))
p = kinematics.fk(ur5, Q, links=["tool0"]).poses[:, 0, :3, 3]
print("FK of other samples within the sampled reach + 1 cm:", bool(np.linalg.norm(p, axis=1).max() < ws.reach + 0.01))
