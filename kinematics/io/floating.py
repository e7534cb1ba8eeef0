"""``floating_base``: a fixed-base model -> the same robot on a free-flyer root joint.

As ``pinocchio.buildModelFromUrdf(path, pinocchio.JointModelFreeFlyer())`` does, a floating joint
named ``root_joint`` is put above the model's root link, hanging from a new root link named
``universe`` (Pinocchio's name of its world frame); a name the model already uses gets a suffix
(``root_joint_2``). So ``q = (x, y, z, qx, qy, qz, qw, q_1 ... q_n)`` (``nq = 7 + n``), the
velocity vector and the Jacobians' columns are ``6 + n`` (whole-body), and the root link's pose
in the world is the first seven entries of q.

The new model is built once per model object (cached as long as the model lives) and keeps the
fixed-base model in ``base_model`` (Pinocchio is checked against its own free-flyer construction
of the original URDF). Its URDF text is the original with the new link and joint inserted.

>>> from kinematics.io import default_catalogue
>>> ur5 = default_catalogue().get("ur5")
>>> fb = with_floating_base(ur5)
>>> fb.joint_names[0], fb.root, fb.nq, fb.nv, fb is with_floating_base(ur5)
('root_joint', 'universe', 13, 12, True)
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import replace

import numpy as np

from ..errors import URDFError
from ..model.derived import PerModel
from ..model.robot import Joint, RobotModel, frozen_array

#: the names Pinocchio gives the free-flyer root joint and the world frame
ROOT_JOINT = "root_joint"
UNIVERSE = "universe"


def _unique(name: str, taken) -> str:
    out, i = name, 1
    while out in taken:
        i += 1
        out = f"{name}_{i}"
    return out


def _esc(name: str) -> str:
    return name.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;").replace(">", "&gt;")


_ROBOT_TAG = re.compile(r"<robot\b[^>]*?>", re.S)


def _build(model: RobotModel) -> RobotModel:
    link = _unique(UNIVERSE, set(model.links))
    joint_name = _unique(ROOT_JOINT, set(model.joint_map))
    root_joint = Joint(name=joint_name, type="floating", parent=link, child=model.root,
                       origin=frozen_array(np.eye(4)), axis=frozen_array([0.0, 0.0, 1.0]))
    text = model.urdf
    match = _ROBOT_TAG.search(re.sub(r"<!--.*?-->", lambda m: " " * len(m.group(0)), text, flags=re.S))
    if match is None:  # pragma: no cover - every model was read from URDF text
        raise URDFError(f"model {model.name!r}: no <robot> element in its URDF")
    insert = (f'\n  <link name="{_esc(link)}"/>\n  <joint name="{_esc(joint_name)}" type="floating">'
              f'<parent link="{_esc(link)}"/><child link="{_esc(model.root)}"/></joint>')
    urdf = text[:match.end()] + insert + text[match.end():]
    return replace(
        model,
        links=(link,) + model.links,
        joints=(root_joint,) + model.joints,
        root=link,
        joint_names=(joint_name,) + model.joint_names,
        content_hash=hashlib.sha256(urdf.encode("utf-8")).hexdigest(),
        urdf=urdf,
        visuals={link: (), **dict(model.visuals)},
        base_model=model,
    )


_floating = PerModel(_build)


def with_floating_base(model: RobotModel) -> RobotModel:
    """The model on a free-flyer root joint (see the module doc); built once per model object."""
    return _floating(model)
