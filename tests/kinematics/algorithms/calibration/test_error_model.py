"""The error model: the nominal chain at zero parameters, and its analytic Jacobian."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics.algorithms.calibration.errors_model import ErrorModel, so3_left_jacobian_inverse
from kinematics.algorithms.calibration.identification import residual_and_jacobian
from kinematics.engine.poe import compile_model
from kinematics.errors import UnknownLinkError
from kinematics.spatial.lie import se3_exp, so3_log

CHAINS = [("ur5", "tool0"), ("panda", "panda_link8"), ("puma560_standard", None), ("stanford_arm", None)]


def chain(catalogue, mid, link):
    model = catalogue.get(mid)
    return model, link or model.links[-1]


@pytest.mark.parametrize("mid,link", CHAINS)
def test_at_zero_parameters_the_chain_is_the_products_fk(catalogue, mid, link):
    model, link = chain(catalogue, mid, link)
    em = ErrorModel(model, link, "pose", base="fixed", tool="fixed")
    Q = model.sample_configurations(20, np.random.default_rng(0))
    T = em.predict(Q, np.zeros(len(em.names)))
    assert np.abs(T - compile_model(model).fk(Q, [link])[:, 0]).max() < 1e-13


@pytest.mark.parametrize("mid,link", CHAINS)
@pytest.mark.parametrize("measure", ["position", "pose"])
def test_the_analytic_jacobian_matches_central_differences(catalogue, mid, link, measure):
    model, link = chain(catalogue, mid, link)
    rng = np.random.default_rng(1)
    em = ErrorModel(model, link, measure, point=np.array([0.02, -0.03, 0.05]))
    Q = model.sample_configurations(6, rng)
    x = em.x0 + rng.normal(0.0, 0.02, len(em.x0))  # away from zero: the derivative is exact anywhere
    truth = em.predict(Q, x + rng.normal(0.0, 0.01, len(x)))
    measured = truth[:, :3, 3] if measure == "position" else truth
    r, J = residual_and_jacobian(em, Q, x, measured, rotation_weight=0.7)
    h = 1e-6
    fd = np.empty_like(J)
    for i in range(len(x)):
        e = np.zeros(len(x))
        e[i] = h
        rp = residual_and_jacobian(em, Q, x + e, measured, 0.7, want_jacobian=False)[0]
        rm = residual_and_jacobian(em, Q, x - e, measured, 0.7, want_jacobian=False)[0]
        fd[..., i] = (rp - rm) / (2 * h)
    assert np.abs(J - fd).max() < 1e-7
    assert np.abs(J).max() > 0.1  # not a vacuous comparison


def test_zero_offset_columns_are_the_product_jacobian(catalogue):
    """The derivative with respect to a joint's zero is its column of the PoE world Jacobian."""
    model = catalogue.get("ur5")
    em = ErrorModel(model, "tool0", "pose", base="fixed", tool="fixed")
    Q = model.sample_configurations(5, np.random.default_rng(2))
    _, cols = em.jacobian(Q, np.zeros(len(em.names)))
    J = compile_model(model).jacobian(Q, "tool0", "local_world_aligned")
    for k, name in enumerate(model.joint_names):
        assert np.abs(cols[:, :, em.index[f"{name}.offset"]] - J[:, :, k]).max() < 1e-12


def test_left_jacobian_inverse_is_the_derivative_of_the_log():
    rng = np.random.default_rng(3)
    axes = rng.normal(size=(5, 3))
    phi = axes / np.linalg.norm(axes, axis=1, keepdims=True) * np.array([[1e-6], [0.3], [1.0], [2.0], [3.0]])
    delta = 1e-7 * rng.normal(size=(5, 3))
    R = se3_exp(np.concatenate([np.zeros((5, 3)), phi], axis=1))[:, :3, :3]
    dR = se3_exp(np.concatenate([np.zeros((5, 3)), delta], axis=1))[:, :3, :3]
    got = so3_log(dR @ R) - phi
    want = (so3_left_jacobian_inverse(phi) @ delta[:, :, None])[:, :, 0]
    assert np.abs(got - want).max() < 1e-12


def test_an_unknown_link_is_named(catalogue):
    with pytest.raises(UnknownLinkError, match="tool9"):
        ErrorModel(catalogue.get("ur5"), "tool9")
