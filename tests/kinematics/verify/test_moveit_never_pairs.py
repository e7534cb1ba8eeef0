"""Five pairs MoveIt's shipped SRDFs disable as "Never" collide within the joint limits.

MoveIt's configurations (``ur5_moveit_config/config/ur5.srdf`` of ros-industrial/universal_robot,
``panda_moveit_config/config/panda_arm.xacro`` of moveit/moveit_resources) disable these pairs as
never colliding; on the catalogue's UR5 and Panda (example-robot-data's geometry; MoveIt's
``base_link_inertia`` is the catalogue's ``base_link``) each collides at the configuration below,
within the limits, by our check and by Pinocchio with coal. The product's matrix leaves them
enabled (checked). The configurations are listed in docs/operations/collision.md.
"""

from __future__ import annotations

import numpy as np
import pytest

from kinematics.algorithms import self_collision
from kinematics.io.catalogue import example_robot_data_dir
from kinematics.model.joint_values import limit_violations
from kinematics.verify.pinocchio import compare_collision

#: (model, the pair MoveIt disables as Never, a configuration within the limits where it collides)
NEVER_BUT_COLLIDING = [
    ("ur5", ("base_link", "upper_arm_link"), [-3.58, 1.75, 1.92, 5.83, -4.39, -0.22]),
    ("ur5", ("base_link", "wrist_1_link"), [-3.8, -2.65, -2.79, 0.09, -2.69, -5.06]),
    ("ur5", ("shoulder_link", "wrist_1_link"), [-1.49, 0.05, -3.04, -0.08, 5.93, -2.7]),
    ("ur5", ("shoulder_link", "wrist_2_link"), [1.43, 1.91, 2.74, 5.89, -5.85, -3.67]),
    ("panda", ("panda_link2", "panda_link6"), [-2.56, -1.02, 2.16, -3.06, 2.86, 2.76, -1.61, 0.04]),
]


@pytest.mark.parametrize("model_id, pair, q", NEVER_BUT_COLLIDING)
def test_the_pair_collides_within_the_limits_by_us_and_by_pinocchio(catalogue, model_id, pair, q):
    model = catalogue.get(model_id)
    Q = np.array([q])
    assert not limit_violations(model, Q).any()
    ours = self_collision.check(model, Q, pairs=[pair])
    assert ours.pairs[0] == [pair]
    agreement = compare_collision(model, Q, [pair], [example_robot_data_dir().parent.parent], ours.pairs)
    assert agreement.same_pairs == 1, agreement.mismatches
    # not a grazing contact: 2 mrad of noise on every joint keeps it
    noisy = Q + np.random.default_rng(0).normal(0.0, 2e-3, (20, Q.shape[1]))
    assert self_collision.check(model, noisy, pairs=[pair]).colliding.all()


@pytest.mark.slow
@pytest.mark.parametrize("model_id", ["ur5", "panda"])
def test_the_default_matrix_checks_them(catalogue, model_id, tmp_path):
    matrix = self_collision.matrix(catalogue.get(model_id), cache_dir=tmp_path)  # the default 10,000 samples
    for mid, pair, _ in NEVER_BUT_COLLIDING:
        if mid == model_id:
            assert pair in matrix.enabled() and matrix.counts[pair] > 0
