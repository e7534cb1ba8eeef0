"""DH tables: validation, FK of the table, DH -> URDF, the presets of models/ and their closed forms."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from kinematics import compile_model, parse_urdf
from kinematics.io.catalogue import DEFAULT_PRESETS_DIR, Catalogue
from kinematics.algorithms.dh import dh_tool_pose, dh_transforms
from kinematics.io.dh_table import (
    DEFAULT_EFFORT,
    DEFAULT_PRISMATIC_LIMITS,
    DEFAULT_REVOLUTE_LIMITS,
    DEFAULT_VELOCITY,
    DHTable,
    load_table,
    loads_table,
    table_from_dict,
    table_to_dict,
    table_to_urdf,
)
from kinematics.spatial.rotations import matrix_to_rpy_exact
from kinematics.errors import DHError
from kinematics.spatial.rotations import rpy_to_matrix

#: DH -> URDF must reproduce the DH product to rounding
EXACT = 1e-12
#: agreement with Pinocchio and with other URDFs of the same arm
PARITY = 1e-9

PRESETS = sorted(DEFAULT_PRESETS_DIR.glob("*.yaml"))
PRESET_IDS = [p.stem for p in PRESETS]


def _table(path: Path) -> DHTable:
    return load_table(path)


def _random_q(table: DHTable, n: int, rng) -> np.ndarray:
    lo = np.array([r.urdf_limits[0] for r in table.rows])
    hi = np.array([r.urdf_limits[1] for r in table.rows])
    return rng.uniform(lo, hi, size=(n, table.dof))


def _frame_links(table: DHTable) -> list[str]:
    return [f"frame_{i}" for i in range(1, table.dof + 1)]


# ------------------------------------------------------------------ presets: DH -> URDF exact
def test_every_preset_of_the_issue_is_bundled():
    expected = {
        "planar_2r", "planar_3r", "scara", "rpr_example", "stanford_arm", "puma560_standard",
        "puma560_modified", "rhino", "kuka_lwr4", "kuka_kr5_sixx", "ur5_dh", "panda_dh",
    }
    assert expected <= set(PRESET_IDS)
    for path in PRESETS:  # each cites the source of its numbers
        head = path.read_text().splitlines()[:3]
        assert head[0].startswith("#") and any("Source" in line or "source" in line for line in path.read_text().splitlines() if line.startswith("#")), path.name


@pytest.mark.parametrize("path", PRESETS, ids=PRESET_IDS)
def test_preset_urdf_fk_equals_dh_product(path, rng):
    table = _table(path)
    model = parse_urdf(table_to_urdf(table))
    assert model.joint_names == table.joint_names
    assert model.leaf_links == ("tool",)
    Q = np.vstack([np.zeros(table.dof), _random_q(table, 20, rng)])
    T = compile_model(model).fk(Q, ["frame_0", *_frame_links(table), "tool"])
    np.testing.assert_allclose(T[:, 0], np.broadcast_to(table.base, (len(Q), 4, 4)), rtol=0, atol=EXACT)
    np.testing.assert_allclose(T[:, 1:-1], dh_transforms(table, Q), rtol=0, atol=EXACT)
    np.testing.assert_allclose(T[:, -1], dh_tool_pose(table, Q), rtol=0, atol=EXACT)


@pytest.mark.parametrize("path", PRESETS, ids=PRESET_IDS)
def test_pinocchio_loads_every_generated_urdf_and_agrees(path, rng):
    from kinematics.verify.pinocchio import compare_fk, compare_jacobian

    table = _table(path)
    model = parse_urdf(table_to_urdf(table))
    Q = _random_q(table, 4, rng)
    dev = compare_fk(model, Q)  # every link
    assert dev.max_position_error < PARITY and dev.max_rotation_error < PARITY
    assert compare_jacobian(model, Q, "tool") < PARITY


def test_catalogue_lists_presets_with_readable_ids(catalogue):
    for stem in PRESET_IDS:
        entry = catalogue.entry(stem)
        assert entry.source == "preset"
        model = catalogue.get(stem)
        assert model.name == _table(entry.path).name
        assert model.leaf_links == ("tool",)


# ------------------------------------------------------------------ textbook closed forms
def test_planar_2r_closed_form(rng):
    """De Luca's 2R planar arm: p = (a1 c1 + a2 c12, a1 s1 + a2 s12, 0), phi = q1 + q2."""
    table = _table(DEFAULT_PRESETS_DIR / "planar_2r.yaml")
    a1, a2 = table.rows[0].a, table.rows[1].a
    Q = _random_q(table, 50, rng)
    T = compile_model(parse_urdf(table_to_urdf(table))).fk(Q, ["tool"])[:, 0]
    q1, q12 = Q[:, 0], Q[:, 0] + Q[:, 1]
    p = np.stack([a1 * np.cos(q1) + a2 * np.cos(q12), a1 * np.sin(q1) + a2 * np.sin(q12), 0 * q1], axis=1)
    np.testing.assert_allclose(T[:, :3, 3], p, rtol=0, atol=EXACT)
    np.testing.assert_allclose(np.arctan2(T[:, 1, 0], T[:, 0, 0]), np.angle(np.exp(1j * q12)), rtol=0, atol=EXACT)


def test_planar_3r_modified_closed_form(rng):
    """Lin Shao's "Frame Attachment" example (Craig rows (0,0,0,q1), (l1,0,0,q2), (l2,0,0,q3)), tool l3 along x3."""
    table = _table(DEFAULT_PRESETS_DIR / "planar_3r.yaml")
    assert table.convention == "modified"
    l1, l2, l3 = table.rows[1].a, table.rows[2].a, table.tool[0, 3]
    Q = _random_q(table, 50, rng)
    T = compile_model(parse_urdf(table_to_urdf(table))).fk(Q, ["tool"])[:, 0]
    c = np.cumsum(Q, axis=1)
    x = l1 * np.cos(c[:, 0]) + l2 * np.cos(c[:, 1]) + l3 * np.cos(c[:, 2])
    y = l1 * np.sin(c[:, 0]) + l2 * np.sin(c[:, 1]) + l3 * np.sin(c[:, 2])
    np.testing.assert_allclose(T[:, :3, 3], np.stack([x, y, 0 * x], axis=1), rtol=0, atol=EXACT)


def test_scara_closed_form_of_de_luca(rng):
    """De Luca's SCARA, step 6: T = [[c124, s124, 0, a1 c1 + a2 c12], [s124, -c124, 0, a1 s1 + a2 s12],
    [0, 0, -1, d1 + q3 + d4]]."""
    table = _table(DEFAULT_PRESETS_DIR / "scara.yaml")
    assert [r.type for r in table.rows] == ["revolute", "revolute", "prismatic", "revolute"]
    a1, a2, d1, d4 = table.rows[0].a, table.rows[1].a, table.rows[0].d, table.rows[3].d
    assert d4 < 0  # "d4 < 0 (opposite to z3)"
    Q = _random_q(table, 50, rng)
    T = compile_model(parse_urdf(table_to_urdf(table))).fk(Q, ["tool"])[:, 0]
    q1, q2, q3, q4 = Q.T
    c1, s1, c12, s12 = np.cos(q1), np.sin(q1), np.cos(q1 + q2), np.sin(q1 + q2)
    c124, s124 = np.cos(q1 + q2 + q4), np.sin(q1 + q2 + q4)
    expected = np.zeros((len(Q), 4, 4))
    expected[:, 0] = np.stack([c124, s124, 0 * q1, a1 * c1 + a2 * c12], axis=1)
    expected[:, 1] = np.stack([s124, -c124, 0 * q1, a1 * s1 + a2 * s12], axis=1)
    expected[:, 2] = np.stack([0 * q1, 0 * q1, -1 + 0 * q1, d1 + q3 + d4], axis=1)
    expected[:, 3, 3] = 1
    np.testing.assert_allclose(T, expected, rtol=0, atol=EXACT)


def test_rpr_example_T3_0_of_spong_example(rng):
    """Spong-convention RPR example: T3_0 = [[c1 c3, -c1 s3, s1, s1 (d2 + d3)], [s1 c3, -s1 s3, -c1, -c1 (d2 + d3)],
    [s3, c3, 0, d1]]."""
    table = _table(DEFAULT_PRESETS_DIR / "rpr_example.yaml")
    d1, d3 = table.rows[0].d, table.rows[2].d
    Q = _random_q(table, 50, rng)
    T = compile_model(parse_urdf(table_to_urdf(table))).fk(Q, ["frame_3"])[:, 0]
    th1, d2, th3 = Q.T
    c1, s1, c3, s3 = np.cos(th1), np.sin(th1), np.cos(th3), np.sin(th3)
    z = 0 * th1
    expected = np.stack(
        [
            np.stack([c1 * c3, -c1 * s3, s1, s1 * (d2 + d3)], axis=1),
            np.stack([s1 * c3, -s1 * s3, -c1, -c1 * (d2 + d3)], axis=1),
            np.stack([s3, c3, z, d1 + z], axis=1),
            np.stack([z, z, z, 1 + z], axis=1),
        ],
        axis=1,
    )
    np.testing.assert_allclose(T, expected, rtol=0, atol=EXACT)


def test_stanford_arm_closed_form(rng):
    """Spong's closed form of the Stanford arm end point (d1 added; this table's theta3 = -90 deg
    shifts the wrist angle: its q4 is Spong's q4 + 90 deg)."""
    table = _table(DEFAULT_PRESETS_DIR / "stanford_arm.yaml")
    assert [r.type for r in table.rows] == ["revolute"] * 2 + ["prismatic"] + ["revolute"] * 3
    d1, d2, d6 = table.rows[0].d, table.rows[1].d, table.rows[5].d
    Q = _random_q(table, 50, rng)
    T = compile_model(parse_urdf(table_to_urdf(table))).fk(Q, ["frame_6"])[:, 0]
    q1, q2, d3, q4, q5, _ = Q.T
    q4 = q4 - math.pi / 2
    c1, s1, c2, s2 = np.cos(q1), np.sin(q1), np.cos(q2), np.sin(q2)
    c4, s4, c5, s5 = np.cos(q4), np.sin(q4), np.cos(q5), np.sin(q5)
    x = c1 * s2 * d3 - s1 * d2 + d6 * (c1 * c2 * c4 * s5 + c1 * c5 * s2 - s1 * s4 * s5)
    y = s1 * s2 * d3 + c1 * d2 + d6 * (c1 * s4 * s5 + c2 * c4 * s1 * s5 + c5 * s1 * s2)
    z = d1 + c2 * d3 + d6 * (c2 * c5 - c4 * s2 * s5)
    np.testing.assert_allclose(T[:, :3, 3], np.stack([x, y, z], axis=1), rtol=0, atol=EXACT)


def _rot(axis, angle):
    axis = np.asarray(axis, float)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def test_rhino_matches_wens_product_of_exponentials(rng):
    """Wen's Rhino arm: h1 = y (P), h2 = z, h3 = h4 = h5 = x, h6 = y; p01 = l1 y, p23 = l2 z, p34 = l3 y,
    p45 = l4 y, p56 = l6 y; R06 = rot(h2,q2) ... rot(h6,q6), p06 as in Wen's notes."""
    table = _table(DEFAULT_PRESETS_DIR / "rhino.yaml")
    l1, l2, l3, l4, l6 = 0.1, 0.26, 0.23, 0.23, 0.12  # the values the preset's comment states
    x, y, z = np.eye(3)
    h = [y, z, x, x, x, y]
    p = [l1 * y, 0 * y, l2 * z, l3 * y, l4 * y, l6 * y]
    Q = _random_q(table, 30, rng)
    T = dh_tool_pose(table, Q)
    for n, q in enumerate(Q):
        R = np.eye(3)
        pos = p[0] + q[0] * h[0]
        for i in range(1, 6):  # p06 = (p01 + q1 h1) + p12 + R12 p23 + ... ; R_{i-1,i} = rot(h_i, q_i)
            pos = pos + R @ p[i] if i > 1 else pos + p[1]
            R = R @ _rot(h[i], q[i])
        np.testing.assert_allclose(T[n, :3, :3], R, rtol=0, atol=EXACT)
        np.testing.assert_allclose(T[n, :3, 3], pos, rtol=0, atol=EXACT)


def test_rhino_position_formula_uses_each_link_vector():
    """Guard for the test above: at q = 0 the tool is at p01 + p23 + p34 + p45 + p56."""
    table = _table(DEFAULT_PRESETS_DIR / "rhino.yaml")
    T0 = dh_tool_pose(table, np.zeros((1, 6)))[0]
    np.testing.assert_allclose(T0[:3, 3], [0, 0.1 + 0.23 + 0.23 + 0.12, 0.26], atol=EXACT)
    np.testing.assert_allclose(T0[:3, :3], np.eye(3), atol=EXACT)


def test_puma560_standard_and_modified_give_the_same_tool_pose(rng):
    std = _table(DEFAULT_PRESETS_DIR / "puma560_standard.yaml")
    mod = _table(DEFAULT_PRESETS_DIR / "puma560_modified.yaml")
    assert (std.convention, mod.convention) == ("standard", "modified")
    Q = _random_q(std, 50, rng)
    np.testing.assert_allclose(dh_tool_pose(std, Q), dh_tool_pose(mod, Q), rtol=0, atol=EXACT)
    # and through the generated URDFs
    Ts = compile_model(parse_urdf(table_to_urdf(std))).fk(Q, ["tool"])
    Tm = compile_model(parse_urdf(table_to_urdf(mod))).fk(Q, ["tool"])
    np.testing.assert_allclose(Ts, Tm, rtol=0, atol=EXACT)
    # the wrist centre is where the two tables put it: d3 to the side, a2 + a3 out, d4 up
    T0 = dh_tool_pose(std, np.zeros((1, 6)))[0]
    np.testing.assert_allclose(T0[:3, 3], [0.4318 + 0.0203, -0.15005, 0.4318], atol=EXACT)


def test_panda_dh_equals_the_franka_urdf_flange(catalogue, rng):
    """Franka's published modified DH table + flange = panda_link8 of example-robot-data's URDF."""
    table = _table(DEFAULT_PRESETS_DIR / "panda_dh.yaml")
    panda = catalogue.get("panda")
    Q = panda.sample_configurations(20, rng)
    cols = [panda.q_index[n] for n in table.joint_names]
    T = compile_model(panda).fk(Q, ["panda_link8"])[:, 0]
    np.testing.assert_allclose(dh_tool_pose(table, Q[:, cols]), T, rtol=0, atol=PARITY)


def test_ur5_dh_equals_the_ur5_urdf_from_base_to_tool0(catalogue, rng):
    """Universal Robots' DH table = ROS 'base' -> 'tool0' of example-robot-data's UR5.

    The URDF writes pi/2 as 1.570796325 (error 1.8e-9 rad), so agreement is to 1e-10."""
    table = _table(DEFAULT_PRESETS_DIR / "ur5_dh.yaml")
    ur5 = catalogue.get("ur5")
    Q = ur5.sample_configurations(20, rng)
    cols = [ur5.q_index[n] for n in table.joint_names]
    T = compile_model(ur5).fk(Q, ["base", "tool0"])
    rel = np.linalg.inv(T[:, 0]) @ T[:, 1]
    np.testing.assert_allclose(dh_tool_pose(table, Q[:, cols]), rel, rtol=0, atol=1e-10)


# ------------------------------------------------------------------ generated URDF structure
def _table_dict(**over):
    d = {
        "name": "t",
        "convention": "standard",
        "angles": "degrees",
        "joints": [
            {"type": "revolute", "a": 0, "alpha": -90, "d": 0.412, "theta": 0, "name": "j1", "limits": [-170, 170]},
            {"type": "revolute", "a": 0.3, "alpha": 90, "d": 0.154, "theta": 10},
            {"type": "prismatic", "a": 0, "alpha": 0, "d": 0.2, "theta": -90, "limits": [0.3, 1.2]},
            {"type": "prismatic", "a": 0.1, "alpha": 30, "d": 0, "theta": 45},
        ],
        "base": [[1, 0, 0, 0.5], [0, 1, 0, 0], [0, 0, 1, 0.1], [0, 0, 0, 1]],
        "tool": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.1], [0, 0, 0, 1]],
    }
    d.update(over)
    return d


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_generated_urdf_names_limits_and_visuals(convention):
    table = table_from_dict(_table_dict(convention=convention))
    model = parse_urdf(table_to_urdf(table))
    assert model.name == "t" and model.root == "world"
    assert model.joint_names == ("j1", "joint_2", "joint_3", "joint_4")
    expected_links = {"world", "tool", *(f"frame_{i}" for i in range(5))}
    if convention == "standard":
        expected_links |= {f"motion_{i}" for i in range(1, 5)}
    assert set(model.links) == expected_links
    assert model.leaf_links == ("tool",)
    jm = model.joint_map
    assert [jm[n].type for n in model.joint_names] == ["revolute", "revolute", "prismatic", "prismatic"]
    assert (jm["j1"].limits.lower, jm["j1"].limits.upper) == pytest.approx((-170 * math.pi / 180, 170 * math.pi / 180))
    assert (jm["joint_2"].limits.lower, jm["joint_2"].limits.upper) == pytest.approx(DEFAULT_REVOLUTE_LIMITS)
    assert (jm["joint_3"].limits.lower, jm["joint_3"].limits.upper) == pytest.approx((0.3, 1.2))
    assert (jm["joint_4"].limits.lower, jm["joint_4"].limits.upper) == pytest.approx(DEFAULT_PRISMATIC_LIMITS)
    assert jm["j1"].limits.effort == DEFAULT_EFFORT and jm["j1"].limits.velocity == DEFAULT_VELOCITY
    # a cylinder along every joint axis, a segment along each nonzero a and d, a box on world and tool
    for name in model.links:
        assert model.visuals[name], f"link {name} has no visual"
    kinds = [v.kind for vs in model.visuals.values() for v in vs]
    assert kinds.count("cylinder") >= 4 + 5 and kinds.count("box") == 2
    # joint-axis cylinders lie along the joint's axis: z of the joint frame
    poe = compile_model(model)
    M = dict(zip(poe.link_names, poe.M))
    for i, jname in enumerate(model.joint_names):
        link = f"frame_{i}" if convention == "standard" else f"frame_{i + 1}"
        axis_world = poe.w[poe.joint_names.index(jname)]
        cyl = [v for v in model.visuals[link] if v.kind == "cylinder"]
        assert any(np.allclose((M[link][:3, :3] @ v.origin[:3, :3])[:, 2], axis_world) for v in cyl)


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_dh_transforms_follow_the_formulas_of_design(convention, rng):
    """Independent product of elementary matrices (docs/design.md) vs dh_transforms."""
    d = _table_dict(convention=convention, angles="radians")
    for row in d["joints"]:
        row.pop("limits", None)
    table = table_from_dict(d)
    Q = rng.uniform(-2, 2, size=(10, 4))

    def rz(t):
        T = np.eye(4); T[:3, :3] = _rot([0, 0, 1], t); return T

    def rx(t):
        T = np.eye(4); T[:3, :3] = _rot([1, 0, 0], t); return T

    def tr(x=0.0, z=0.0):
        T = np.eye(4); T[0, 3] = x; T[2, 3] = z; return T

    for n, q in enumerate(Q):
        T = np.array(d["base"], float)
        for i, row in enumerate(d["joints"]):
            th = row["theta"] + (q[i] if row["type"] == "revolute" else 0)
            dd = row["d"] + (q[i] if row["type"] == "prismatic" else 0)
            if convention == "standard":
                A = rz(th) @ tr(z=dd) @ tr(x=row["a"]) @ rx(row["alpha"])
            else:
                A = rx(row["alpha"]) @ tr(x=row["a"]) @ rz(th) @ tr(z=dd)
            T = T @ A
            np.testing.assert_allclose(dh_transforms(table, Q)[n, i], T, rtol=0, atol=EXACT)
        np.testing.assert_allclose(dh_tool_pose(table, Q)[n], T @ np.array(d["tool"], float), atol=EXACT)


def test_rpy_of_generated_origins_is_exact_at_the_gimbal_lock(rng):
    """Rot_x(alpha) Rot_z(theta) with alpha = theta = 90 deg has pitch = -90 deg."""
    cases = [rpy_to_matrix(rng.uniform(-4, 4, 3)) for _ in range(200)]
    for a, t in [(math.pi / 2, math.pi / 2), (-math.pi / 2, math.pi / 2), (math.pi / 2 + 1e-9, math.pi / 2)]:
        c, s, ct, st = math.cos(a), math.sin(a), math.cos(t), math.sin(t)
        cases.append(np.array([[1, 0, 0], [0, c, -s], [0, s, c]]) @ np.array([[ct, -st, 0], [st, ct, 0], [0, 0, 1]]))
    for R in cases:
        np.testing.assert_allclose(rpy_to_matrix(matrix_to_rpy_exact(R)), R, rtol=0, atol=1e-15)


# ------------------------------------------------------------------ table <-> dict, files
@pytest.mark.parametrize("angles", ["radians", "degrees"])
def test_table_to_dict_round_trip(angles):
    table = table_from_dict(_table_dict())
    again = table_from_dict(json.loads(json.dumps(table_to_dict(table, angles=angles))))
    assert again.joint_names == table.joint_names and again.convention == table.convention
    for r, s in zip(table.rows, again.rows):
        assert (r.type, r.name) == (s.type, s.name)
        assert np.allclose([r.a, r.alpha, r.d, r.theta], [s.a, s.alpha, s.d, s.theta], rtol=0, atol=1e-15)
        assert (r.limits is None) == (s.limits is None)
        if r.limits:
            assert np.allclose(r.limits, s.limits, rtol=0, atol=1e-15)
    np.testing.assert_allclose(again.base, table.base, atol=0)
    np.testing.assert_allclose(again.tool, table.tool, atol=0)


def test_degrees_apply_to_alpha_theta_and_revolute_limits_only():
    t = table_from_dict(_table_dict())
    assert t.rows[0].alpha == pytest.approx(-math.pi / 2)
    assert t.rows[1].theta == pytest.approx(math.radians(10))
    assert t.rows[0].limits == pytest.approx((math.radians(-170), math.radians(170)))
    assert t.rows[2].limits == pytest.approx((0.3, 1.2))  # prismatic: metres
    assert t.rows[2].theta == pytest.approx(-math.pi / 2) and t.rows[2].d == 0.2
    assert t.rows[0].d == 0.412  # lengths untouched


def test_defaults_offset_abbreviations_and_xyz_rpy_base():
    t = table_from_dict(
        {
            "joints": [
                {"type": "R", "a": 1, "alpha": 0, "d": 0, "theta": 0.1, "offset": 0.2},
                {"type": "p", "a": 0, "alpha": 0, "d": 0.5, "theta": 0, "offset": 0.25, "limits": {"lower": 0, "upper": 1}},
            ],
            "base": {"xyz": [1, 2, 3], "rpy": [0, 0, math.pi / 2]},
            "tool": None,
        }
    )
    assert (t.name, t.convention, t.angles) == ("dh_robot", "standard", "radians")
    assert [r.type for r in t.rows] == ["revolute", "prismatic"]
    assert t.rows[0].theta == pytest.approx(0.3) and t.rows[1].d == pytest.approx(0.75)
    assert t.rows[1].limits == (0.0, 1.0)
    np.testing.assert_allclose(t.base[:3, 3], [1, 2, 3])
    np.testing.assert_allclose(t.base[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)
    np.testing.assert_array_equal(t.tool, np.eye(4))


def test_near_rigid_base_is_projected_to_a_rotation():
    c = round(math.cos(0.3), 7)
    s = round(math.sin(0.3), 7)
    t = table_from_dict(_table_dict(base=[[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]))
    R = t.base[:3, :3]
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(R, [[c, -s, 0], [s, c, 0], [0, 0, 1]], atol=1e-7)


def test_load_table_yaml_and_json(tmp_path):
    d = _table_dict()
    (tmp_path / "t.json").write_text(json.dumps(d))
    import yaml

    (tmp_path / "t.yml").write_text(yaml.safe_dump(d))
    a, b = load_table(tmp_path / "t.json"), load_table(tmp_path / "t.yml")
    Q = np.random.default_rng(0).uniform(0.3, 1, (5, 4))
    np.testing.assert_allclose(dh_tool_pose(a, Q), dh_tool_pose(b, Q), atol=0)
    # YAML 1.1 reads 1e-3 as a string; it is accepted as a number
    t = loads_table("joints:\n  - {type: revolute, a: 1e-3, alpha: 0, d: 0, theta: 0}\n")
    assert t.rows[0].a == 1e-3


@pytest.mark.parametrize(
    "name, text, message",
    [
        ("t.txt", "{}", "must end in .yaml"),
        ("missing.yaml", None, "cannot read"),
        ("bad.yaml", "joints: [a, : b", "not valid YAML"),
        ("bad.json", "{'a': 1}", "not valid JSON"),
        ("nan.yaml", "joints:\n  - {type: revolute, a: .nan, alpha: 0, d: 0, theta: 0}\n", "joints[0].a"),
    ],
)
def test_load_table_errors_name_the_file(tmp_path, name, text, message):
    path = tmp_path / name
    if text is not None:
        path.write_text(text)
    with pytest.raises(DHError) as info:
        load_table(path)
    assert message in str(info.value) and name in str(info.value)


# ------------------------------------------------------------------ bad tables
def _row(**over):
    r = {"type": "revolute", "a": 0.1, "alpha": 0, "d": 0, "theta": 0}
    r.update(over)
    return r


@pytest.mark.parametrize(
    "table, field",
    [
        ([], "a DH table must be a mapping"),
        ({"joints": [_row()], "convention": "craig"}, "convention"),
        ({"joints": [_row()], "angles": "grad"}, "angles"),
        ({"joints": [_row()], "units": "m"}, "unknown field(s) ['units']"),
        ({}, "joints: missing"),
        ({"joints": []}, "joints: a DH table needs at least one row"),
        ({"joints": {"type": "revolute"}}, "joints: expected a list"),
        ({"joints": [_row(), "x"]}, "joints[1]: expected a mapping"),
        ({"joints": [_row(type="helical")]}, "joints[0].type"),
        ({"joints": [_row(type=None)]}, "joints[0].type: missing"),
        ({"joints": [_row(), _row(alpha=float("nan"))]}, "joints[1].alpha"),
        ({"joints": [_row(d=float("inf"))]}, "joints[0].d"),
        ({"joints": [_row(a=1e300)]}, "joints[0].a: 1e+300 is beyond"),
        ({"joints": [_row(type="prismatic", limits=[0, 1e9])]}, "joints[0].limits"),
        ({"joints": [_row()], "base": [[1, 0, 0, 1e12], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}, "base[0][3]"),
        ({"joints": [_row(theta="ninety")]}, "joints[0].theta"),
        ({"joints": [_row(a=True)]}, "joints[0].a"),
        ({"joints": [{"type": "revolute", "a": 0, "alpha": 0, "theta": 0}]}, "joints[0].d: missing"),
        ({"joints": [_row(length=1)]}, "joints[0]: unknown field(s) ['length']"),
        ({"joints": [_row(limits=[1, -1])]}, "joints[0].limits"),
        ({"joints": [_row(limits=[0, 1, 2])]}, "joints[0].limits"),
        ({"joints": [_row(limits=[0, float("nan")])]}, "joints[0].limits.upper"),
        ({"joints": [_row(name="j"), _row(name="j")]}, "joints[1].name: 'j'"),
        ({"joints": [_row(name="tool_joint")]}, "joints[0].name: 'tool_joint' is reserved"),
        ({"joints": [_row(name="a b")]}, "joints[0].name"),
        ({"joints": [_row()], "name": "<robot>"}, "name"),
        ({"joints": [_row()], "base": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}, "base"),
        ({"joints": [_row()], "base": [[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}, "base: not a rigid transform"),
        ({"joints": [_row()], "tool": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, 0], [0, 0, 0, 1]]}, "tool: not a rigid transform"),
        ({"joints": [_row()], "tool": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]]}, "tool: not a rigid transform"),
        ({"joints": [_row()], "tool": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, float("nan")], [0, 0, 0, 1]]}, "tool[2][3]"),
        ({"joints": [_row()], "tool": {"xyz": [0, 0], "rpy": [0, 0, 0]}}, "tool.xyz"),
    ],
)
def test_bad_tables_are_refused_naming_the_field(table, field):
    with pytest.raises(DHError) as info:
        table_from_dict(table)
    assert field in str(info.value)


def test_too_many_rows_is_refused():
    from kinematics.io.dh_table import MAX_DH_ROWS

    with pytest.raises(DHError, match="at most"):
        table_from_dict({"joints": [_row()] * (MAX_DH_ROWS + 1)})


def test_dh_transforms_checks_the_shape_of_q():
    table = table_from_dict({"joints": [_row(), _row()]})
    with pytest.raises(DHError, match=r"\(N, 2\)"):
        dh_transforms(table, np.zeros((3, 3)))
    assert dh_transforms(table, [0.1, 0.2]).shape == (1, 2, 4, 4)


def test_presets_directory_override(tmp_path):
    """A catalogue built on another presets directory lists exactly its tables."""
    (tmp_path / "My Arm.yaml").write_text((DEFAULT_PRESETS_DIR / "planar_2r.yaml").read_text())
    cat = Catalogue(robots_dir=tmp_path / "none", presets_dir=tmp_path)
    assert cat.ids() == ["my_arm"]
    assert cat.get("my_arm").joint_names == ("joint_1", "joint_2")


def test_rows_and_tables_built_in_code_are_validated():
    from kinematics.io.dh_table import DHRow

    with pytest.raises(DHError, match="type"):
        DHRow("helical", 0, 0, 0, 0, "j")
    with pytest.raises(DHError, match="alpha"):
        DHRow("revolute", 0, float("nan"), 0, 0, "j")
    with pytest.raises(DHError, match="limits"):
        DHRow("prismatic", 0, 0, 0, 0, "j", (1.0, 0.0))
    row = DHRow("revolute", 0.1, 0, 0, 0, "j")
    with pytest.raises(DHError, match="convention"):
        DHTable("t", "craig", (row,))
    with pytest.raises(DHError, match="tool: not a rigid"):
        DHTable("t", "standard", (row,), tool=np.diag([1.0, 1.0, -1.0, 1.0]))
    with pytest.raises(DHError, match="reserved"):
        table_to_urdf(DHTable("t", "standard", (DHRow("revolute", 0.1, 0, 0, 0, "tool_joint"),)))
    with pytest.raises(DHError, match="used by another row"):
        table_to_urdf(DHTable("t", "modified", (row, row)))


def test_generated_urdf_builds_a_yourdfpy_scene_of_primitives():
    """What a URDF viewer does: yourdfpy builds the scene graph from the visual primitives."""
    import io

    import yourdfpy

    for path in (DEFAULT_PRESETS_DIR / "kuka_lwr4.yaml", DEFAULT_PRESETS_DIR / "panda_dh.yaml"):
        table = load_table(path)
        robot = yourdfpy.URDF.load(io.BytesIO(table_to_urdf(table).encode()), build_scene_graph=True, load_meshes=True)
        assert robot.validate()
        assert len(robot.scene.geometry) >= 2 * table.dof
        q = np.linspace(-0.5, 0.5, table.dof)
        robot.update_cfg(q)
        np.testing.assert_allclose(robot.get_transform("tool", "world"), dh_tool_pose(table, q)[0], atol=1e-12)
