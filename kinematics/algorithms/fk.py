"""Forward kinematics: the pose ``T_world_link`` of links for a batch of configurations.

``T_world_L(q) = T_world_root · exp([S_1] q_1) ... exp([S_k] q_k) · M_L`` over the moving
joints on the path from the root to ``L`` (the engine evaluates the product; a base pose
``T_world_root`` is the identity unless given).

Worked examples from the literature (De Luca's Robotics 1 slides, Spong's convention), on the
bundled DH presets:

>>> import numpy as np
>>> from kinematics.io import default_catalogue
>>> catalogue = default_catalogue()

The 2R planar arm (``a1 = 0.5``, ``a2 = 0.4``): the tip at ``(a1 c_1 + a2 c_12, a1 s_1 + a2 s_12, 0)``.

>>> planar = catalogue.get("planar_2r")
>>> forward_kinematics(planar, [[np.pi / 6, np.pi / 3]], ["tool"])[0, 0, :3, 3].round(12) + 0.0
array([0.4330127, 0.65     , 0.       ])

The SCARA (``a1 = 0.325``, ``a2 = 0.275``, ``d1 = 0.4``, ``d4 = -0.1``): the tool at
``(a1 c_1 + a2 c_12, a1 s_1 + a2 s_12, d1 + q3 + d4)``.

>>> scara = catalogue.get("scara")
>>> q = [[np.pi / 2, -np.pi / 2, -0.05, 0.3]]
>>> forward_kinematics(scara, q, ["tool"])[0, 0, :3, 3].round(12) + 0.0
array([0.275, 0.325, 0.25 ])

The RPR arm of the forward-kinematics example in Spong's convention (``d1 = 0.3``, ``d3 = 0.1``):
``p = (s1 (d2 + d3), -c1 (d2 + d3), d1)``.

>>> rpr = catalogue.get("rpr_example")
>>> forward_kinematics(rpr, [[0.0, 0.2, 0.5]], ["tool"])[0, 0, :3, 3].round(12) + 0.0
array([ 0. , -0.3,  0.3])
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..engine.poe import compile_model
from ..model.robot import RobotModel
from .base import poses_in_world


def forward_kinematics(model: RobotModel, Q, links: Sequence[str] | None = None, base: np.ndarray | None = None,
                       out: np.ndarray | None = None, tool: np.ndarray | None = None) -> np.ndarray:
    """Poses ``T_world_link`` (N, L, 4, 4) of ``links`` (None: every link, in ``model.links``
    order) for joint values ``Q`` (N, dof) in ``model.joint_names`` order.

    ``base``: ``T_world_root`` per configuration (N, 4, 4), or None for the root frame.
    ``out``: a C-contiguous float64 array of the result's shape to write into (no base).
    ``tool``: ``T_link_tool`` (4, 4): the poses are then ``T_world_link @ T_link_tool`` (a tool
    frame, or a point with the link's axes, on every link returned).
    """
    T = compile_model(model).fk(Q, links, out=out, tool=tool)
    return poses_in_world(T, base)
