"""PoE and zero-configuration-axes descriptions -> URDF (kinematics.io.poe_model, axes_model):
FK equals the product of exponentials and Wen's formula to 1e-12, the screws come back,
and validation errors name the field."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import api, compile_model
from kinematics.errors import AxesError, PoEError
from kinematics.io import default_catalogue
from kinematics.io.axes_model import axes_from_dict, axes_to_dict, axes_to_urdf, load_axes, model_from_axes
from kinematics.io.poe_model import (adjoint, load_poe, model_from_poe, poe_from_dict, poe_to_dict, poe_to_urdf)
from kinematics.spatial.transforms import exp_screws
from tests.paths import FIXTURES

DESCRIPTIONS = FIXTURES / "poe_axes"
L1, L2 = 0.6, 0.4
MR_M = [[0, 0, 1, L1], [0, 1, 0, 0], [-1, 0, 0, -L2], [0, 0, 0, 1]]
MR_S = [[0, 0, 1, 0, 0, 0], [0, -1, 0, 0, 0, -L1], [1, 0, 0, 0, -L2, 0]]


def product_of_exponentials(S, M, Q):
    """exp([S_1] q_1) ... exp([S_n] q_n) M for a batch Q (N, n)."""
    S = np.asarray(S, float)
    revolute = np.linalg.norm(S[:, :3], axis=1) > 0.5
    w = np.where(revolute[:, None], S[:, :3], S[:, 3:])
    r = np.where(revolute[:, None], np.cross(S[:, :3], S[:, 3:]), 0.0)
    E = exp_screws(w, r, revolute, Q)
    out = np.broadcast_to(np.eye(4), (len(Q), 4, 4))
    for k in range(S.shape[0]):
        out = out @ E[:, k]
    return out @ np.asarray(M, float)


def tool_fk(model, Q):
    return compile_model(model).fk(Q, ["tool"])[:, 0]


def test_modern_robotics_3r_space_screws(rng):
    desc = poe_from_dict({"M": MR_M, "joints": [{"S": s} for s in MR_S]})
    model = model_from_poe(desc)
    Q = rng.uniform(-np.pi, np.pi, (50, 3))
    np.testing.assert_allclose(tool_fk(model, Q), product_of_exponentials(MR_S, MR_M, Q), atol=1e-12)
    np.testing.assert_allclose(compile_model(model).S, MR_S, atol=1e-15)  # GET /models/{id}/screws
    # turning joint 2 by pi/2 swings the tool to (L1 + L2, 0, 0)
    np.testing.assert_allclose(tool_fk(model, np.array([[0, np.pi / 2, 0]]))[0, :3, 3], [L1 + L2, 0, 0], atol=1e-15)


def test_body_screws_give_the_same_robot(rng):
    space = poe_from_dict({"M": MR_M, "joints": [{"S": s} for s in MR_S]})
    body = poe_from_dict({"M": MR_M, "joints": [{"B": b.tolist()} for b in space.B]})
    assert body.frame == "body"
    np.testing.assert_allclose(body.S, space.S, atol=1e-15)
    Q = rng.uniform(-3, 3, (20, 3))
    # T = M exp([B_1] q_1) ... exp([B_n] q_n): the same poses
    M = np.array(MR_M, float)
    body_product = M @ product_of_exponentials(space.B, np.eye(4), Q)
    np.testing.assert_allclose(tool_fk(model_from_poe(body), Q), body_product, atol=1e-12)
    np.testing.assert_allclose(adjoint(M) @ space.B.T, space.S.T, atol=1e-15)


def test_ur5_as_a_product_of_exponentials_is_the_ur5(rng):
    """The screws and tool0's home pose of the UR5, as a PoE description, give its FK back."""
    ur5 = default_catalogue().get("ur5")
    poe = compile_model(ur5)
    M = poe.M[poe.link_names.index("tool0")]
    desc = poe_from_dict({"name": "ur5_poe", "M": M.tolist(),
                          "joints": [{"S": s.tolist(), "name": n} for s, n in zip(poe.S, poe.joint_names)]})
    model = model_from_poe(desc)
    Q = ur5.sample_configurations(50, rng)
    np.testing.assert_allclose(tool_fk(model, Q), poe.fk(Q, ["tool0"])[:, 0], atol=1e-12)
    np.testing.assert_allclose(compile_model(model).S, poe.S, atol=1e-12)
    assert model.joint_names == ur5.joint_names


def test_prismatic_and_continuous_joints(rng):
    S = [[0, 0, 0, 0, 0, 1], [0, 0, 1, 0, -1, 0], [0, 0, 0, 1, 0, 0]]
    desc = poe_from_dict({"M": {"xyz": [1, 0, 0.5]}, "joints": [
        {"S": S[0], "limits": [0, 0.5]}, {"S": S[1], "type": "continuous"}, {"S": S[2], "type": "P"}]})
    model = model_from_poe(desc)
    assert [j.type for j in model.moving_joints] == ["prismatic", "continuous", "prismatic"]
    Q = rng.uniform(-2, 2, (20, 3))
    np.testing.assert_allclose(tool_fk(model, Q), product_of_exponentials(S, desc.M, Q), atol=1e-12)


def test_canonical_dict_reads_back_to_the_same_urdf():
    desc = load_poe(DESCRIPTIONS / "mr_3r_spatial.yaml")
    again = poe_from_dict(poe_to_dict(desc))
    assert poe_to_urdf(again) == poe_to_urdf(desc)
    assert poe_to_dict(desc)["joints"][2] == {"S": [1, 0, 0, 0, -0.4, 0], "type": "revolute", "name": "j3",
                                              "limits": [-2, 2]}
    axes = load_axes(DESCRIPTIONS / "wen_rhino.yaml")
    assert axes_to_urdf(axes_from_dict(axes_to_dict(axes))) == axes_to_urdf(axes)


@pytest.mark.parametrize("description, message", [
    ({"joints": [{"S": [0, 0, 1, 0, 0, 0]}]}, "M: missing"),
    ({"M": [[0, 0, 1, 0.6], [0, 1, 0, 0], [-1, 0, 1, -0.4], [0, 0, 0, 1]], "joints": [{"S": [0, 0, 1, 0, 0, 0]}]},
     "M: not a rigid transform"),  # the handout's typo (M[2][2] = 1)
    ({"M": MR_M, "joints": [{"S": [0, 0, 2, 0, 0, 0]}]}, r"joints\[0\].S: the angular part w must be a unit"),
    ({"M": MR_M, "joints": [{"S": [0, 0, 1, 0, 0, 1]}]}, r"joints\[0\].S: pitch"),
    ({"M": MR_M, "joints": [{"S": [0, 0, 0, 0, 0, 2]}]}, r"joints\[0\].S: a prismatic joint's screw"),
    ({"M": MR_M, "joints": [{"S": [0, 0, 1, 0, 0, 0], "type": "prismatic"}]}, r"joints\[0\].type"),
    ({"M": MR_M, "joints": [{"S": [0, 0, 1, 0, 0, 0]}, {"B": [0, 0, 1, 0, 0, 0]}]}, r"joints\[1\].B: every joint"),
    ({"M": MR_M, "joints": [{"S": [0, 0, 1, 0, 0, 0], "B": [0, 0, 1, 0, 0, 0]}]}, "exactly one"),
    ({"M": MR_M, "joints": [{"S": [0, 0, 1, 0, 0]}]}, r"joints\[0\].S: expected 6 numbers"),
    ({"M": MR_M, "joints": [{"S": [0, 0, 1, 0, 0, 0], "name": "tool"}]}, "reserved"),
    ({"M": MR_M, "joints": [{"S": [0, 0, 1, 0, 0, 0], "name": "a"}, {"S": [0, 0, 1, 0, 0, 0], "name": "a"}]},
     "also the name"),
    ({"M": MR_M, "joints": [{"S": [0, 0, 1, 0, 0, 0], "type": "continuous", "limits": [0, 1]}]}, "no limits"),
    ({"M": MR_M, "joints": []}, "at least one"),
    ({"M": MR_M, "joints": [{"S": [0, 0, 1, 0, 0, 0]}], "screws": []}, "unknown field"),
])
def test_poe_errors_name_the_field(description, message):
    with pytest.raises(PoEError, match=message):
        poe_from_dict(description)


# ---------------------------------------------------------------------- zero-configuration axes
def rot(h, q):
    h = np.asarray(h, float)
    K = np.array([[0, -h[2], h[1]], [h[2], 0, -h[0]], [-h[1], h[0], 0]])
    return np.eye(3) + np.sin(q) * K + (1 - np.cos(q)) * K @ K


X, Y, Z = np.eye(3)


def test_wen_scara_equals_the_lecture(rng):
    """Wen's SCARA: R_04 = R_01 R_12 R_23,
    p_04 = R_01 p_12 + R_01 R_12 p_23 + R_01 R_12 R_23 (p_34 + q_4 h_4)."""
    l1, l2, l3 = 0.4, 0.3, 0.1
    model = model_from_axes(load_axes(DESCRIPTIONS / "wen_scara.yaml"))
    Q = rng.uniform(-2, 2, (30, 4))
    T = tool_fk(model, Q)
    for q, t in zip(Q, T):
        R01, R12, R23 = rot(Z, q[0]), rot(Z, q[1]), rot(Z, q[2])
        p = R01 @ (l1 * Y) + R01 @ R12 @ (l2 * Y) + R01 @ R12 @ R23 @ (l3 * Z + q[3] * Z)
        np.testing.assert_allclose(t[:3, :3], R01 @ R12 @ R23, atol=1e-12)
        np.testing.assert_allclose(t[:3, 3], p, atol=1e-12)


def test_wen_rhino_equals_the_lecture(rng):
    """Wen's Rhino arm: R_06 = rot(h2, q2) ... rot(h6, q6);
    p_06 = (p_01 + q_1 h_1) + p_12 + R_12 p_23 + ... + R_15 p_56."""
    l1, l2, l3, l4, l6 = 0.1, 0.26, 0.23, 0.23, 0.12
    model = model_from_axes(load_axes(DESCRIPTIONS / "wen_rhino.yaml"))
    Q = rng.uniform(-0.4, 0.4, (30, 6))
    T = tool_fk(model, Q)
    for q, t in zip(Q, T):
        R12, R23, R34, R45, R56 = rot(Z, q[1]), rot(X, q[2]), rot(X, q[3]), rot(X, q[4]), rot(Y, q[5])
        p = (l1 * Y + q[0] * Y) + 0 + R12 @ (l2 * Z) + R12 @ R23 @ (l3 * Y) + R12 @ R23 @ R34 @ (l4 * Y) \
            + R12 @ R23 @ R34 @ R45 @ (l6 * Y)
        np.testing.assert_allclose(t[:3, :3], R12 @ R23 @ R34 @ R45 @ R56, atol=1e-12)
        np.testing.assert_allclose(t[:3, 3], p, atol=1e-12)


def test_wen_rhino_is_the_rhino_preset(rng):
    """The rhino DH preset was built from the same lecture: the same tool position (its frame 6
    turns differently, the DH frames having their own x axes)."""
    model = model_from_axes(load_axes(DESCRIPTIONS / "wen_rhino.yaml"))
    preset = default_catalogue().get("rhino")
    Q = rng.uniform(-0.3, 0.3, (20, 6))
    np.testing.assert_allclose(tool_fk(model, Q)[:, :3, 3], tool_fk(preset, Q)[:, :3, 3], atol=1e-12)


def test_tool_orientation_and_degrees():
    desc = axes_from_dict({"angles": "degrees", "joints": [{"type": "R", "h": [0, 0, 1], "limits": [-90, 90]}],
                           "p_nT": [0.5, 0, 0], "R_nT": {"rpy": [0, 0, 90]}})
    model = model_from_axes(desc)
    assert model.joint_map["joint_1"].limits.upper == pytest.approx(np.pi / 2)
    T = tool_fk(model, np.array([[np.pi / 2]]))[0]
    np.testing.assert_allclose(T[:3, 3], [0, 0.5, 0], atol=1e-15)
    np.testing.assert_allclose(T[:3, :3], rot(Z, np.pi), atol=1e-15)


@pytest.mark.parametrize("description, message", [
    ({"joints": [{"type": "R", "h": [0, 0, 2]}]}, r"joints\[0\].h: .* is not a unit vector"),
    ({"joints": [{"type": "R"}]}, r"joints\[0\].h: missing"),
    ({"joints": [{"type": "X", "h": [0, 0, 1]}]}, r"joints\[0\].type"),
    ({"joints": [{"type": "R", "h": [0, 0, 1], "p": [0, 1]}]}, r"joints\[0\].p: expected 3 numbers"),
    ({"joints": [{"type": "R", "h": [0, 0, 1]}], "p_nT": [0, "a", 0]}, r"p_nT\[1\]"),
    ({"joints": [{"type": "R", "h": [0, 0, 1]}], "R_nT": [[1, 0, 0], [0, 1, 0], [0, 0, 2]]}, "R_nT: not a rigid"),
    ({"joints": [{"type": "R", "h": [0, 0, 1], "name": "link_1"}]}, "reserved"),
    ({"joints": [{"type": "R", "h": [0, 0, 1], "limits": [1, 0]}]}, r"joints\[0\].limits"),
    ({"joints": "R"}, "expected a list"),
])
def test_axes_errors_name_the_field(description, message):
    with pytest.raises(AxesError, match=message):
        axes_from_dict(description)


def test_files_and_the_use_case(tmp_path):
    model, canonical = api.model_from_description("axes", DESCRIPTIONS / "wen_scara.yaml")
    assert model.name == "wen_scara" and canonical["joints"][3]["type"] == "prismatic"
    assert api.description_urdf("poe", DESCRIPTIONS / "mr_3r_spatial.yaml").startswith("<?xml")
    bad = tmp_path / "bad.json"
    bad.write_text('{"joints": [{"type": "R", "h": [0, 0, 1]}], "p_nT": [0, 0]}')
    with pytest.raises(AxesError, match="bad.json: p_nT"):
        load_axes(bad)
    with pytest.raises(PoEError, match="must end in"):
        load_poe(tmp_path / "x.txt")
