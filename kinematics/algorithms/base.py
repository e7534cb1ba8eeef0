"""Results of the root frame re-expressed in the world, given the root link's world pose.

With ``B = T_world_root = (R, p)`` (one per configuration):

- poses: ``T_world_L = B @ T_root_L``;
- Jacobians (linear rows first): ``world``: ``w' = R w``, ``v' = R v + p x w'`` (the twist's
  reference point moves to the world origin); ``local_world_aligned``: ``v' = R v``,
  ``w' = R w``; ``local``: unchanged.
"""

from __future__ import annotations

import numpy as np

from ..spatial.reference import Reference


def poses_in_world(T_root_links: np.ndarray, B: np.ndarray | None) -> np.ndarray:
    """``T_world_L = B @ T_root_L`` for poses (N, L, 4, 4) and base poses B (N, 4, 4) (None: unchanged)."""
    if B is None:
        return T_root_links
    return np.matmul(B[:, None], T_root_links)


def jacobian_in_world(J: np.ndarray, B: np.ndarray | None, reference: str) -> np.ndarray:
    """Re-express Jacobians (N, 6, n) of the root frame in the world given base poses B (N, 4, 4)."""
    if B is None or reference == Reference.LOCAL:
        return J
    R, p = B[:, :3, :3], B[:, :3, 3]
    ang = R @ J[:, 3:, :]
    lin = R @ J[:, :3, :]
    if reference == Reference.WORLD:
        lin = lin + np.cross(p[:, :, None], ang, axisa=1, axisb=1, axisc=1)
    return np.concatenate([lin, ang], axis=1)
