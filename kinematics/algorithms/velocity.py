"""Link velocities: for joint values ``q`` and joint velocities ``qdot``, the twist of every link.

Computed in one pass down the tree by the engine (:mod:`kinematics.engine.velocity`): each
joint adds ``qdot_j`` times its axis to the angular velocity (revolute) or to the linear
velocity (prismatic) of the body below it, and a point of a body moves with
``v_B = v_A + ω × (p_B - p_A)``; a mimic joint moves with ``multiplier · qdot[leader]``. The
result equals ``J(q) qdot`` of the three Jacobians (:mod:`kinematics.algorithms.jacobian`)
without forming one Jacobian per link.

Per link, in each reference (linear part first, Pinocchio's ``getFrameVelocity``):

- ``local_world_aligned``: the velocity of the link origin and the angular velocity, world axes
  (the ``linear`` and ``angular`` of the answers);
- ``world``: the velocity of the body point at the world origin, and the angular velocity;
- ``local``: the link-origin velocity and the angular velocity in the link's own axes.

The 2R planar arm (``a1 = 0.5``, ``a2 = 0.4``) at ``q = (0, π/2)`` turning its first joint at
1 rad/s: the tip at ``(0.5, 0.4, 0)`` moves with ``ω × p = (-0.4, 0.5, 0)``.

>>> import numpy as np
>>> from kinematics.io import default_catalogue
>>> planar = default_catalogue().get("planar_2r")
>>> V = velocities(planar, [[0.0, np.pi / 2]], [[1.0, 0.0]], ["tool"])
>>> V["local_world_aligned"][0, 0].round(12) + 0.0
array([-0.4,  0.5,  0. ,  0. ,  0. ,  1. ])
>>> V["world"][0, 0].round(12) + 0.0
array([0., 0., 0., 0., 0., 1.])
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..engine.poe import compile_model
from ..model.robot import RobotModel
from ..spatial.reference import Reference
from .base import jacobian_in_world


def twists_in_world(V: np.ndarray, B: np.ndarray | None, reference: str) -> np.ndarray:
    """Twists (N, L, 6) of the root frame re-expressed in the world of base poses B (N, 4, 4)
    (as the columns of a Jacobian: :func:`kinematics.algorithms.base.jacobian_in_world`)."""
    if B is None or reference == Reference.LOCAL:
        return V
    return np.swapaxes(jacobian_in_world(np.swapaxes(V, 1, 2), B, reference), 1, 2)


def velocities(model: RobotModel, Q, Qd, links: Sequence[str] | None = None, tool: np.ndarray | None = None,
               base: np.ndarray | None = None) -> dict[Reference, np.ndarray]:
    """Twists of ``links`` (None: every link, ``model.links`` order) for joint values ``Q`` and
    velocities ``Qd`` (N, dof): ``{reference: (N, L, 6)}``, linear part first.

    ``tool``: ``T_link_tool`` (4, 4), the frame whose velocity is wanted (for every link; a
    point is a tool with the link's axes). ``base``: ``T_world_root`` per configuration
    (N, 4, 4) of a base at rest, or None for the root frame.
    """
    V = compile_model(model).velocity(np.asarray(Q, dtype=float), np.asarray(Qd, dtype=float), links, tool)
    return {ref: twists_in_world(v, base, ref) for ref, v in V.items()}
