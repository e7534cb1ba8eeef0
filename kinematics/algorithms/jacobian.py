"""Jacobians: 6 x dof, linear rows first, in one of the three references.

Column j of the space (``world``) Jacobian is ``Ad(exp([S_1]q_1) ... exp([S_{j-1}]q_{j-1})) S_j``
(zero for joints off the path; a mimic joint adds ``multiplier`` times its column to its
leader's). ``local_world_aligned`` moves the reference point to the link origin; ``local``
also turns the axes into the link's.

The 2R planar arm (``a1 = 0.5``, ``a2 = 0.4``) at ``q = (0, π/2)``: the tip's geometric
Jacobian is ``[[-a1 s_1 - a2 s_12, -a2 s_12], [a1 c_1 + a2 c_12, a2 c_12]]`` in its x, y
rows, and both joints turn it about z:

>>> import numpy as np
>>> from kinematics.io import default_catalogue
>>> planar = default_catalogue().get("planar_2r")
>>> J = jacobian(planar, [[0.0, np.pi / 2]], "tool", "local_world_aligned")[0]
>>> J.round(12) + 0.0
array([[-0.4, -0.4],
       [ 0.5,  0. ],
       [ 0. ,  0. ],
       [ 0. ,  0. ],
       [ 0. ,  0. ],
       [ 1. ,  1. ]])
"""

from __future__ import annotations

import numpy as np

from ..engine.poe import compile_model
from ..model.robot import RobotModel
from ..spatial.reference import Reference
from .base import jacobian_in_world


def jacobian(model: RobotModel, Q, link: str, reference: str = Reference.WORLD,
             base: np.ndarray | None = None, tool: np.ndarray | None = None) -> np.ndarray:
    """Jacobians (N, 6, dof) of ``link``, linear rows first, in ``reference``, for joint values
    ``Q`` (N, dof); ``base``: ``T_world_root`` per configuration, or None for the root frame.

    ``tool``: ``T_link_tool`` (4, 4): the Jacobian of the frame at that offset from the link, as
    Pinocchio has it for a frame added there: ``local_world_aligned`` (and ``world`` after a base)
    rows take the tool origin as their reference point (``v_tool = v_link + ω × (p_tool -
    p_link)``), ``local`` also turns into the tool's axes. A point is a tool with the link's axes.
    """
    J = compile_model(model).jacobian(Q, link, reference, tool=tool)
    return jacobian_in_world(J, base, reference)
