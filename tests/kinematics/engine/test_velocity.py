"""The compiled velocity kernel (kinematics/engine/velocity.py): one pass down the tree equals
``J(q) qdot`` of the engine's own Jacobians, for every link, in the three references, with and
without a tool offset; batches equal their rows bit for bit; chunk boundaries; models without
moving joints."""

from __future__ import annotations

import zlib

import numpy as np
import pytest

from kinematics import compile_model, parse_urdf
from kinematics.errors import KinematicsError
from kinematics.spatial.reference import REFERENCES
from kinematics.spatial.rotations import rpy_to_matrix
from kinematics.spatial.transforms import make_transform
from tests.paths import FIXTURES

#: largest deviation of the propagated velocities from J(q) qdot
TOLERANCE = 1e-12
TOOL = make_transform(rpy_to_matrix(np.array([0.3, -0.5, 1.1])), np.array([0.1, -0.2, 0.3]))


def _catalogue_ids():
    from tests.catalogue_sample import catalogue_ids

    return catalogue_ids()  # a fixed sample; every model with KIN_TEST_FULL_CATALOGUE=1


def _jacobian_products(poe, Q, Qd, links, tool=None):
    return {ref: np.stack([np.einsum("nij,nj->ni", poe.jacobian(Q, link, ref, tool=tool), Qd) for link in links], axis=1)
            for ref in REFERENCES}


def _check(poe, Q, Qd, links=None, tool=None):
    links = list(poe.link_names) if links is None else links
    V = poe.velocity(Q, Qd, links, tool=tool)
    expected = _jacobian_products(poe, Q, Qd, links, tool)
    for ref in REFERENCES:
        assert V[ref].shape == (Q.shape[0], len(links), 6)
        err = float(np.max(np.abs(V[ref] - expected[ref]))) if V[ref].size else 0.0
        assert err <= TOLERANCE, f"{ref}: {err:.3e}"
    return V


@pytest.mark.slow
@pytest.mark.parametrize("model_id", _catalogue_ids())
def test_velocity_is_jacobian_times_qdot_on_catalogue(catalogue, model_id):
    from kinematics.errors import URDFError

    try:
        model = catalogue.get(model_id)
    except URDFError as exc:
        pytest.skip(f"{model_id}: {exc}")
    poe = compile_model(model)
    rng = np.random.default_rng(zlib.crc32(model_id.encode()))
    Q = model.sample_configurations(7, rng)
    Qd = rng.uniform(-2, 2, Q.shape)
    _check(poe, Q, Qd)
    _check(poe, Q, Qd, list(model.leaf_links), tool=TOOL)


@pytest.mark.parametrize("fixture", ["tree_mimic.urdf", "spatial_3r.urdf", "planar_3r.urdf"])
def test_velocity_on_fixtures_with_tools(fixture, rng):
    model = parse_urdf((FIXTURES / fixture).read_text())
    poe = compile_model(model)
    Q = model.sample_configurations(40, rng)
    Qd = rng.uniform(-3, 3, Q.shape)
    _check(poe, Q, Qd)
    _check(poe, Q, Qd, tool=TOOL)


def test_mimic_joint_moves_with_its_leader(catalogue, rng):
    """panda's second finger mimics the first: its link moves along its axis at multiplier x qdot."""
    model = catalogue.get("panda")
    poe = compile_model(model)
    Q = model.sample_configurations(5, rng)
    Qd = np.zeros_like(Q)
    finger = model.q_index["panda_finger_joint1"]
    Qd[:, finger] = 0.1
    V = _check(poe, Q, Qd, ["panda_leftfinger", "panda_rightfinger", "panda_hand"])
    lin = V["local_world_aligned"][..., :3]
    assert np.allclose(np.linalg.norm(lin[:, 0], axis=1), 0.1)
    assert np.allclose(np.linalg.norm(lin[:, 1], axis=1), 0.1)  # the mimic finger (multiplier 1)
    assert np.allclose(lin[:, 0], -lin[:, 1])  # opposite directions
    assert np.allclose(V["local_world_aligned"][:, 2], 0.0)  # the hand does not move


def test_batch_rows_equal_single_configurations_and_chunks(catalogue, rng):
    model = catalogue.get("ur5")
    poe = compile_model(model)
    Q = model.sample_configurations(600, rng)  # beyond two chunks of 256
    Qd = rng.uniform(-1, 1, Q.shape)
    V = poe.velocity(Q, Qd)
    for n in (0, 255, 256, 511, 599):
        one = poe.velocity(Q[n : n + 1], Qd[n : n + 1])
        for ref in REFERENCES:
            assert np.array_equal(one[ref][0], V[ref][n])  # bit for bit
    _check(poe, Q, Qd)


def test_zero_velocity_and_empty_batches(catalogue):
    model = catalogue.get("ur5")
    poe = compile_model(model)
    V = poe.velocity(np.ones((3, 6)), np.zeros((3, 6)))
    assert all(np.all(v == 0.0) for v in V.values())
    V = poe.velocity(np.zeros((0, 6)), np.zeros((0, 6)))
    assert V["world"].shape == (0, len(model.links), 6)


def test_model_without_moving_joints_has_zero_velocities():
    model = parse_urdf('<robot name="r"><link name="a"/><link name="b"/><joint name="f" type="fixed">'
                       '<parent link="a"/><child link="b"/></joint></robot>')
    V = compile_model(model).velocity(np.zeros((2, 0)), np.zeros((2, 0)))
    assert V["local"].shape == (2, 2, 6) and np.all(V["local"] == 0.0)


def test_shapes_are_checked(catalogue):
    poe = compile_model(catalogue.get("ur5"))
    with pytest.raises(KinematicsError, match="q and qdot"):
        poe.velocity(np.zeros((2, 6)), np.zeros((3, 6)))
    with pytest.raises(KinematicsError, match="tool offset"):
        poe.velocity(np.zeros((2, 6)), np.zeros((2, 6)), tool=np.eye(3))
