"""URDF -> DH: tables of catalogue arms, special axis geometry, round trips and refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kinematics import compile_model, load_urdf, parse_urdf
from kinematics.io.catalogue import DEFAULT_PRESETS_DIR
from kinematics.algorithms.dh import dh_tool_pose, urdf_to_dh
from kinematics.io.dh_table import load_table, table_from_dict, table_to_dict, table_to_urdf
from kinematics.tolerances import AGREEMENT_TOLERANCE as EXTRACT_TOLERANCE
from kinematics.errors import DHError, NoDHFormError, UnknownLinkError

from tests.paths import FIXTURES

#: the table's FK (with base and tool) must equal the URDF's
PARITY = 1e-9
CONVENTIONS = ("standard", "modified")

#: catalogue arms and the tip of their chain (None: the only leaf)
ARMS = [
    ("ur5", "tool0"),
    ("xarm7", None),
    ("z1", None),
    ("so100", None),
    ("panda", "panda_link8"),
    ("panda", "panda_hand_tcp"),
    ("kinova", "j2s6s200_end_effector"),
    ("baxter", "left_gripper"),
]


def _check_fk(model, table, tip, rng, n=25, tol=PARITY):
    """Largest deviation of the table's tool pose from the URDF's FK of ``tip`` at random q."""
    Q = model.sample_configurations(n, rng, continuous_range=math.pi)
    cols = [model.q_index[name] for name in table.joint_names]
    ours = dh_tool_pose(table, Q[:, cols])
    theirs = compile_model(model).fk(Q, [tip])[:, 0]
    err = float(np.max(np.abs(ours - theirs)))
    assert err < tol, f"{model.name} -> {tip}: {err:.3g}"
    return err


@pytest.mark.parametrize("convention", CONVENTIONS)
@pytest.mark.parametrize("model_id, tip", ARMS, ids=[f"{m}-{t}" for m, t in ARMS])
def test_catalogue_arm_table_reproduces_the_urdf(catalogue, model_id, tip, convention, rng):
    model = catalogue.get(model_id)
    table = urdf_to_dh(model, tip=tip, convention=convention)
    tip = tip or model.leaf_links[0]
    assert table.convention == convention
    chain = [j.name for j in model.path_joints(tip) if j.moving]
    assert table.joint_names == tuple(chain)
    for row, name in zip(table.rows, chain):  # the URDF's limits are carried
        j = model.joint_map[name]
        if j.type == "continuous":
            assert row.limits is None
        else:
            assert row.limits == (j.limits.lower, j.limits.upper)
    _check_fk(model, table, tip, rng)


@pytest.mark.parametrize("convention", CONVENTIONS)
@pytest.mark.parametrize("model_id, tip", [("ur5", "tool0"), ("panda", "panda_link8"), ("z1", None)])
def test_catalogue_arm_round_trip_through_urdf(catalogue, model_id, tip, convention, rng):
    """URDF -> DH -> URDF: the generated model's tool follows the original tip."""
    model = catalogue.get(model_id)
    table = urdf_to_dh(model, tip=tip, convention=convention)
    rebuilt = parse_urdf(table_to_urdf(table))
    Q = model.sample_configurations(10, rng)
    cols = [model.q_index[n] for n in rebuilt.joint_names]
    ours = compile_model(rebuilt).fk(Q[:, cols], ["tool"])[:, 0]
    theirs = compile_model(model).fk(Q, [tip or model.leaf_links[0]])[:, 0]
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=PARITY)
    # the regenerated URDF keeps the joint limits
    for name in rebuilt.joint_names:
        a, b = model.joint_map[name].limits, rebuilt.joint_map[name].limits
        if model.joint_map[name].type != "continuous":
            assert (a.lower, a.upper) == pytest.approx((b.lower, b.upper), abs=1e-15)


PRESETS = sorted(DEFAULT_PRESETS_DIR.glob("*.yaml"))


@pytest.mark.parametrize("convention", CONVENTIONS)
@pytest.mark.parametrize("path", PRESETS, ids=[p.stem for p in PRESETS])
def test_preset_round_trip_dh_urdf_dh_urdf(path, convention, rng):
    """DH -> URDF -> DH (either convention) -> URDF gives the same FK of the tool."""
    table = load_table(path)
    first = parse_urdf(table_to_urdf(table))
    again = urdf_to_dh(first, convention=convention)  # tool is the only leaf
    second = parse_urdf(table_to_urdf(again))
    assert second.joint_names == first.joint_names
    Q = first.sample_configurations(20, rng)
    T1 = compile_model(first).fk(Q, ["tool"])
    T2 = compile_model(second).fk(Q, ["tool"])
    np.testing.assert_allclose(T2, T1, rtol=0, atol=PARITY)
    np.testing.assert_allclose(dh_tool_pose(again, Q), dh_tool_pose(table, Q), rtol=0, atol=PARITY)


def _params(table):
    return np.array([[r.a, r.alpha, r.d, r.theta] for r in table.rows])


def test_modified_extraction_recovers_the_textbook_puma_table():
    """Craig-style frames of the arm of puma560_standard.yaml: the modified preset."""
    std = load_table(DEFAULT_PRESETS_DIR / "puma560_standard.yaml")
    mod = load_table(DEFAULT_PRESETS_DIR / "puma560_modified.yaml")
    back = urdf_to_dh(parse_urdf(table_to_urdf(std)), convention="modified")
    np.testing.assert_allclose(_params(back), _params(mod), rtol=0, atol=1e-12)


def test_modified_extraction_of_the_franka_urdf_gives_franka_s_table(catalogue):
    """Franka's published modified DH (a, alpha, d) from example-robot-data's panda.urdf."""
    back = urdf_to_dh(catalogue.get("panda"), tip="panda_link8", convention="modified")
    franka = load_table(DEFAULT_PRESETS_DIR / "panda_dh.yaml")
    p_back, p_franka = _params(back), _params(franka)
    np.testing.assert_allclose(p_back[:, :2], p_franka[:, :2], rtol=0, atol=1e-12)  # a, alpha
    np.testing.assert_allclose(p_back[:6, 2:], p_franka[:6, 2:], rtol=0, atol=1e-12)  # d, theta
    assert back.rows[6].d == pytest.approx(0.107)  # the flange lands in d7 (on the last axis)


def test_special_axes_fixture(rng):
    """Prismatic first joint, coincident P/R axes, fixed joints between moving ones,
    anti-parallel, parallel, intersecting and skew axes, a reversed non-unit axis."""
    model = load_urdf(FIXTURES / "dh" / "special_axes.urdf")
    for convention in CONVENTIONS:
        table = urdf_to_dh(model, convention=convention)
        assert table.joint_names == ("lift", "spin", "shoulder", "elbow", "wrist_roll", "wrist_skew")
        assert [r.type for r in table.rows] == ["prismatic"] + ["revolute"] * 5
        _check_fk(model, table, "tcp", rng, n=50)
    std = urdf_to_dh(model, convention="standard")
    # lift and spin share one line: a = 0 and alpha = 0 between them (coincident axes)
    assert (std.rows[0].a, std.rows[0].alpha) == (0.0, 0.0)
    # shoulder (axis -y) and elbow (axis +y) are anti-parallel: alpha = pi, a = their distance
    assert abs(std.rows[2].alpha) == pytest.approx(math.pi)
    assert abs(std.rows[2].a) == pytest.approx(0.3)


def _random_chain(rng, n, parallel_pairs=True):
    """A random serial chain with fixed joints sprinkled in and some parallel/intersecting axes."""
    links = ['<link name="l0"/>']
    joints = []
    k = 0
    prev_axis = np.array([0.0, 0.0, 1.0])
    for i in range(n):
        if rng.random() < 0.3:  # a fixed joint first
            k += 1
            links.append(f'<link name="l{k}"/>')
            xyz, rpy = rng.normal(0, 0.2, 3), rng.uniform(-3, 3, 3)
            joints.append(
                f'<joint name="f{k}" type="fixed"><parent link="l{k - 1}"/><child link="l{k}"/>'
                f'<origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}" rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/></joint>'
            )
        k += 1
        links.append(f'<link name="l{k}"/>')
        kind = rng.choice(["revolute", "prismatic", "continuous"], p=[0.6, 0.25, 0.15])
        style = rng.choice(["random", "same", "origin"]) if parallel_pairs else "random"
        xyz = rng.normal(0, 0.2, 3) if style != "origin" else np.zeros(3)
        rpy = rng.uniform(-3, 3, 3) if style == "random" else np.zeros(3)
        axis = rng.normal(size=3) if style == "random" else prev_axis
        prev_axis = axis
        limit = '<limit lower="-2" upper="2" effort="1" velocity="1"/>' if kind != "continuous" else ""
        joints.append(
            f'<joint name="j{i}" type="{kind}"><parent link="l{k - 1}"/><child link="l{k}"/>'
            f'<origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}" rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/>'
            f'<axis xyz="{axis[0]} {axis[1]} {axis[2]}"/>{limit}</joint>'
        )
    k += 1
    links.append(f'<link name="l{k}"/>')
    xyz, rpy = rng.normal(0, 0.2, 3), rng.uniform(-3, 3, 3)
    joints.append(
        f'<joint name="tip" type="fixed"><parent link="l{k - 1}"/><child link="l{k}"/>'
        f'<origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}" rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/></joint>'
    )
    return parse_urdf('<robot name="random_chain">' + "".join(links + joints) + "</robot>"), f"l{k}"


@pytest.mark.parametrize("seed", range(12))
def test_random_chains_both_conventions(seed):
    rng = np.random.default_rng(seed)
    model, tip = _random_chain(rng, int(rng.integers(1, 8)))
    for convention in CONVENTIONS:
        table = urdf_to_dh(model, convention=convention)
        _check_fk(model, table, tip, rng)
        # and the table survives its JSON form
        again = table_from_dict(table_to_dict(table))
        _check_fk(model, again, tip, rng)


# ------------------------------------------------------------------ refusals
def test_tree_without_a_tip_is_refused_listing_the_leaves(catalogue):
    with pytest.raises(NoDHFormError) as info:
        urdf_to_dh(catalogue.get("panda"))
    msg = str(info.value)
    assert "panda_leftfinger" in msg and "panda_hand_tcp" in msg and "tip" in msg


def test_mimic_joint_on_the_chain_is_refused(catalogue):
    with pytest.raises(NoDHFormError, match="panda_finger_joint2.*mimics"):
        urdf_to_dh(catalogue.get("panda"), tip="panda_rightfinger")
    # the other finger's chain has no mimic joint
    table = urdf_to_dh(catalogue.get("panda"), tip="panda_leftfinger")
    assert table.rows[-1].type == "prismatic"


def test_unknown_tip_and_chain_without_motion_are_refused(catalogue):
    with pytest.raises(UnknownLinkError, match="no_such_link"):
        urdf_to_dh(catalogue.get("ur5"), tip="no_such_link")
    with pytest.raises(NoDHFormError, match="no moving joint"):
        urdf_to_dh(catalogue.get("ur5"), tip="base_link")
    with pytest.raises(DHError, match="convention"):
        urdf_to_dh(catalogue.get("ur5"), tip="tool0", convention="craig")


def _near_parallel(eps: float):
    return parse_urdf(
        f"""<robot name="near_parallel"><link name="a"/><link name="b"/><link name="c"/><link name="d"/>
<joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
  <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
<joint name="j2" type="revolute"><parent link="b"/><child link="c"/><origin xyz="0.5 0.1 0" rpy="{-eps} 0 0"/>
  <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
<joint name="j3" type="revolute"><parent link="c"/><child link="d"/><origin xyz="0.4 0 0"/>
  <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint></robot>"""
    )


@pytest.mark.parametrize("eps", [1e-12, 1e-6, 1e-3])
def test_nearly_parallel_axes_that_dh_can_represent(eps, rng):
    model = _near_parallel(eps)
    table = urdf_to_dh(model)
    _check_fk(model, table, "d", rng, tol=EXTRACT_TOLERANCE)


def test_ill_conditioned_nearly_parallel_axes_are_refused():
    """Axes 1e-8 rad apart: the common normal is 1e7 m away and the table cannot reach 1e-9."""
    with pytest.raises(NoDHFormError, match="nearly parallel"):
        urdf_to_dh(_near_parallel(1e-8))


#: presets whose table is the one the extraction's frame rules pick (the others differ by a
#: legitimate DH ambiguity: SCARA's heights along parallel axes, the Stanford arm's x signs,
#: the Panda flange landing in d7)
CANONICAL_PRESETS = [
    "kuka_kr5_sixx", "kuka_lwr4", "planar_2r", "planar_3r", "puma560_modified", "puma560_standard",
    "rhino", "rpr_example", "ur5_dh",
]


@pytest.mark.parametrize("stem", CANONICAL_PRESETS)
def test_extraction_recovers_textbook_tables(stem):
    table = load_table(DEFAULT_PRESETS_DIR / f"{stem}.yaml")
    back = urdf_to_dh(parse_urdf(table_to_urdf(table)), convention=table.convention)
    np.testing.assert_allclose(_params(back), _params(table), rtol=0, atol=1e-12)
    np.testing.assert_allclose(back.base, table.base, rtol=0, atol=1e-12)
    np.testing.assert_allclose(back.tool, table.tool, rtol=0, atol=1e-12)
    assert [r.type for r in back.rows] == [r.type for r in table.rows]
