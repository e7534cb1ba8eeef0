"""The numpy engine of models with floating and planar joints (``engine/tree.py``), held to
definitions rather than to Pinocchio: finite differences of FK along ``q ⊕ ε e_i`` give the
Jacobian's columns, twists are ``J v``, ``integrate`` stays on the manifold, and on models of
one-dof joints the tree walk equals the PoE kernels."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics.engine.poe import PoEModel, compile_model
from kinematics.engine.rooted import FloatingRootModel
from kinematics.engine.tree import TreeModel
from kinematics.io.floating import with_floating_base
from kinematics.io.urdf import load_urdf
from kinematics.spatial.lie import so3_log

from tests.paths import FIXTURES

MODELS = ["floating_planar_tree.urdf", "floating_base_arm.urdf"]


@pytest.fixture(params=MODELS)
def model(request):
    return load_urdf(FIXTURES / request.param)


def test_compile_model_picks_the_tree_walk_for_multi_dof_models(model, catalogue):
    assert type(compile_model(model)) is TreeModel
    assert isinstance(compile_model(catalogue.get("ur5")), PoEModel)
    # a floating joint at the root alone: the compiled kernels below it (tests/kinematics/engine/test_rooted.py)
    assert type(compile_model(with_floating_base(catalogue.get("ur5")))) is FloatingRootModel


def test_jacobian_columns_are_finite_differences_on_the_manifold(model, rng):
    """``local`` column i = the body twist of ``d/dε T(q ⊕ ε e_i)``: ``T^-1 dT`` (central differences)."""
    eng = compile_model(model)
    Q = model.sample_configurations(3, rng)
    eps = 1e-6
    for link in model.links:
        J = eng.jacobian(Q, link, "local")
        for i in range(model.nv):
            e = np.zeros((3, model.nv))
            e[:, i] = eps
            Tp = eng.fk(eng.integrate(Q, e), [link])[:, 0]
            Tm = eng.fk(eng.integrate(Q, -e), [link])[:, 0]
            T = eng.fk(Q, [link])[:, 0]
            Rt = np.swapaxes(T[:, :3, :3], 1, 2)
            lin = (Rt @ ((Tp[:, :3, 3] - Tm[:, :3, 3]) / (2 * eps))[:, :, None])[:, :, 0]
            ang = so3_log(np.swapaxes(Tm[:, :3, :3], 1, 2) @ Tp[:, :3, :3]) / (2 * eps)
            np.testing.assert_allclose(J[:, :3, i], lin, atol=1e-7, err_msg=f"{link} column {i}")
            np.testing.assert_allclose(J[:, 3:, i], ang, atol=1e-7, err_msg=f"{link} column {i}")


def test_twists_are_jacobians_times_v_in_every_reference(model, rng):
    eng = compile_model(model)
    Q = model.sample_configurations(4, rng)
    V = rng.uniform(-1, 1, (4, model.nv))
    tw = eng.velocity(Q, V)
    for k, link in enumerate(model.links):
        for ref, twists in tw.items():
            J = eng.jacobian(Q, link, ref)
            np.testing.assert_allclose(twists[:, k], (J @ V[:, :, None])[:, :, 0], atol=1e-13)


def test_integrate_keeps_unit_quaternions_and_cos_sin(model, rng):
    eng = compile_model(model)
    Q = model.sample_configurations(5, rng)
    for _ in range(20):
        Q = eng.integrate(Q, rng.normal(scale=2.0, size=(5, model.nv)))
    for s in model.layout:
        if s.type == "floating":
            np.testing.assert_allclose(np.linalg.norm(Q[:, s.q_start + 3:s.q_start + 7], axis=1), 1.0, atol=1e-14)
        elif s.type == "planar":
            np.testing.assert_allclose(np.hypot(Q[:, s.q_start + 2], Q[:, s.q_start + 3]), 1.0, atol=1e-14)
    T = eng.frames(Q)
    R = T[..., :3, :3]
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-13)


def test_floating_joint_places_its_child_at_q(rng):
    """A floating root joint: the root link's pose is exactly (x, y, z, R(qx, qy, qz, qw))."""
    model = load_urdf(FIXTURES / "floating_base_arm.urdf")
    q = np.array(model.neutral)
    q[:3] = [0.5, -1.0, 2.0]
    half = 0.3
    q[3:7] = [0.0, np.sin(half), 0.0, np.cos(half)]  # 0.6 rad about y
    T = compile_model(model).fk(q[None], ["torso"])[0, 0]
    np.testing.assert_allclose(T[:3, 3], [0.5, -1.0, 2.0], atol=1e-15)
    c, s = np.cos(0.6), np.sin(0.6)
    np.testing.assert_allclose(T[:3, :3], [[c, 0, s], [0, 1, 0], [-s, 0, c]], atol=1e-15)


def test_planar_joint_moves_in_the_xy_plane_of_its_frame():
    model = load_urdf(FIXTURES / "floating_base_arm.urdf")
    eng = compile_model(model)
    q = np.array(model.neutral)
    s = model.slot["cart_plane"]
    q[s.q_slice] = [0.2, 0.1, np.cos(0.4), np.sin(0.4)]
    home = eng.fk(model.neutral[None], ["cart"])[0, 0]
    moved = eng.fk(q[None], ["cart"])[0, 0]
    rel = np.linalg.inv(home) @ moved
    np.testing.assert_allclose(rel[:3, 3], [0.2, 0.1, 0.0], atol=1e-15)
    np.testing.assert_allclose(so3_log(rel[:3, :3]), [0, 0, 0.4], atol=1e-15)


@pytest.mark.parametrize("model_id", ["ur5", "panda", "pr2", "double_pendulum_continuous"])
def test_tree_walk_equals_the_poe_kernels_on_one_dof_models(catalogue, model_id, rng):
    model = catalogue.get(model_id)
    tree, poe = TreeModel(model), compile_model(model)
    Q = model.sample_configurations(5, rng)
    np.testing.assert_allclose(tree.fk(Q), poe.fk(Q), atol=1e-12)
    for ref in ("world", "local", "local_world_aligned"):
        for link in model.leaf_links:
            np.testing.assert_allclose(tree.jacobian(Q, link, ref), poe.jacobian(Q, link, ref), atol=1e-12)
