"""IK of models with floating and planar joints: on the manifold (unit quaternions and (cos, sin)
throughout), ``success`` only when FK of the answer (and Pinocchio's) is within tolerance."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import api
from kinematics.algorithms.ik import inverse_kinematics
from kinematics.engine.poe import compile_model
from kinematics.io.floating import with_floating_base
from kinematics.io.urdf import load_urdf, parse_urdf

from tests.paths import FIXTURES


@pytest.mark.parametrize("name,link", [("floating_planar_tree.urdf", "finger"), ("floating_base_arm.urdf", "lower"),
                                       ("floating_base_arm.urdf", "cart")])
def test_reachable_targets_are_solved_on_the_manifold(name, link, rng):
    model = load_urdf(FIXTURES / name)
    targets = compile_model(model).fk(model.sample_configurations(6, rng), [link])[:, 0]
    sol = inverse_kinematics(model, link, targets, max_iterations=100, restarts=5)
    assert sol.success.all() and sol.q.shape == (6, model.nq)
    assert (sol.position_error < 1e-6).all() and (sol.rotation_error < 1e-6).all()
    again = compile_model(model).fk(sol.q, [link])[:, 0]
    np.testing.assert_allclose(again, targets, atol=2e-6)
    for s in model.layout:
        if s.type == "floating":
            np.testing.assert_allclose(np.linalg.norm(sol.q[:, s.q_start + 3:s.q_start + 7], axis=1), 1.0, atol=1e-14)
        if s.type == "planar":
            np.testing.assert_allclose(np.hypot(sol.q[:, s.q_start + 2], sol.q[:, s.q_start + 3]), 1.0, atol=1e-14)


def test_an_unreachable_target_is_not_a_success():
    """A planar joint alone cannot leave its plane nor tilt: the best answer, success false."""
    model = parse_urdf('<robot name="p"><link name="a"/><link name="b"/><joint name="p" type="planar">'
                       '<parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint></robot>')
    target = np.eye(4)
    target[:3, 3] = [0.3, 0.4, 0.5]
    sol = inverse_kinematics(model, "b", target[None], restarts=2, max_iterations=30)
    assert not sol.success[0] and sol.position_error[0] == pytest.approx(0.5, abs=1e-6)
    in_plane = target.copy()
    in_plane[2, 3] = 0.0
    sol = inverse_kinematics(model, "b", in_plane[None])
    assert sol.success[0] and sol.q[0].tolist() == pytest.approx([0.3, 0.4, 1.0, 0.0], abs=1e-7)


def test_whole_body_ik_with_floating_base_verified_by_pinocchio(catalogue):
    target = {"xyz": [0.5, -0.2, 0.8], "rpy": [0.3, -0.2, 1.0]}
    answer = api.ik(catalogue.get("solo12"), target, link="FL_FOOT", floating_base=True, verify=True)
    fb = with_floating_base(catalogue.get("solo12"))
    assert answer.model is fb and answer.solution.q.shape == (1, fb.nq) and answer.solution.success[0]
    assert answer.verification["position_error"][0] < 1e-6 and answer.verification["rotation_error"][0] < 1e-6


def test_seeds_are_validated_and_normalized():
    model = load_urdf(FIXTURES / "floating_base_arm.urdf")
    seed = np.array(model.neutral)
    seed[6] = 2.0
    T = compile_model(model).fk(model.neutral[None], ["lower"])[0, 0]
    from kinematics.errors import ConfigurationNormError

    with pytest.raises(ConfigurationNormError, match="seed: .*joint 'base_free'"):
        api.ik(model, T, link="lower", seed=seed.tolist())
    assert api.ik(model, T, link="lower", seed=seed.tolist(), normalize=True).solution.success[0]


def test_each_target_alone_gets_exactly_its_batch_answer(catalogue):
    """Restarts are drawn per target: a target solved alone gives its batch row bit for bit
    (few iterations, so that restarts and failures are part of it)."""
    ur5 = catalogue.get("ur5")
    fb = api.model_for(ur5, floating_base=True)
    Q = fb.sample_configurations(6, np.random.default_rng(3))
    T = compile_model(fb).fk(Q, ["tool0"])[:, 0]
    options = dict(link="tool0", floating_base=True, restarts=3, random_seed=7, max_iterations=4)
    batch = api.ik(ur5, T, **options).solution
    assert batch.iterations.max() > 4 and not batch.success.all()  # restarts ran, and one target failed
    for k in range(len(T)):
        one = api.ik(ur5, T[k:k + 1], **options).solution
        np.testing.assert_array_equal(one.q[0], batch.q[k])
        assert one.success[0] == batch.success[k] and one.iterations[0] == batch.iterations[k]
