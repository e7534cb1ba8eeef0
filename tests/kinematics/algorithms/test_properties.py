"""Property tests (hypothesis) on the library: random kinematic trees written as URDF text.

Every example is a tree of 1-8 links (chains and branches) joined by revolute, continuous,
prismatic and fixed joints with random origins and non-unit axes, and mimic joints that may
follow a joint on another branch. For each one:

- every FK pose is a rigid transform (R orthonormal, det R = 1, last row 0 0 0 1);
- a batch gives exactly what the configurations give one at a time;
- each of the three Jacobians equals central finite differences of our own FK;
- FK and all Jacobians agree with Pinocchio (``kinematics.verify.pinocchio``) to 1e-9;
- a random DH table -> URDF -> FK equals the direct product of the DH matrices.

Budgets are bounded (``MAX_EXAMPLES`` per property, no deadline) so the file runs in seconds.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from kinematics import REFERENCES, as_batch, compile_model, parse_urdf
from kinematics.algorithms.dh import dh_tool_pose, dh_transforms
from kinematics.io import dh_table as dh
from tests.helpers import PINOCCHIO_TOL

#: examples per property (keeps the file in seconds on 2 cores)
MAX_EXAMPLES = 100
#: agreement with Pinocchio (docs/design.md quality bar)
#: rigid-transform checks on FK output
ORTHO_TOL = 1e-12
#: central-difference step and tolerance (truncation ~h^2, round-off ~eps/h)
FD_STEP = 1e-6
FD_TOL = 1e-6
#: DH product vs FK of the generated URDF
DH_TOL = 1e-9

PROPERTY_SETTINGS = settings(
    max_examples=MAX_EXAMPLES,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)

MOVING = ("revolute", "continuous", "prismatic")

coord = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
angle = st.floats(-np.pi, np.pi, allow_nan=False, allow_infinity=False)


@st.composite
def axes(draw):
    """A non-unit axis, well away from zero (direction random, length in [0.2, 5])."""
    v = np.array([draw(coord) for _ in range(3)])
    n = np.linalg.norm(v)
    if n < 0.2:
        v = np.array([0.0, 0.0, 1.0])
        n = 1.0
    return v / n * draw(st.floats(0.2, 5.0))


@st.composite
def trees(draw):
    """(urdf_text, description) of a random tree with 1-8 links."""
    n_links = draw(st.integers(1, 8))
    joints = []
    moving_independent: list[str] = []
    for i in range(1, n_links):
        parent = draw(st.integers(0, i - 1))  # any earlier link: chains and branches
        jtype = draw(st.sampled_from(MOVING + ("fixed",)))
        xyz = [draw(coord) for _ in range(3)]
        rpy = [draw(angle) for _ in range(3)]
        j = {"name": f"j{i}", "type": jtype, "parent": f"l{parent}", "child": f"l{i}", "xyz": xyz, "rpy": rpy}
        if jtype in MOVING:
            j["axis"] = draw(axes())
            if jtype != "continuous":
                lo = draw(st.floats(-3.0, 0.0))
                j["limit"] = (lo, lo + draw(st.floats(0.0, 6.0)))
            # a mimic follows an earlier independent joint of the same kind (any branch)
            leaders = [n for n, t in moving_independent if (t == "prismatic") == (jtype == "prismatic")]
            if leaders and draw(st.booleans()):
                j["mimic"] = (draw(st.sampled_from(leaders)), draw(st.floats(-2.0, 2.0)), draw(st.floats(-1.0, 1.0)))
            else:
                moving_independent.append((j["name"], jtype))
        joints.append(j)
    return _urdf(n_links, joints), joints


def _fmt(v) -> str:
    return " ".join(repr(float(x)) for x in v)


def _urdf(n_links: int, joints: list[dict]) -> str:
    lines = ['<?xml version="1.0"?>', '<robot name="random_tree">']
    lines += [f'  <link name="l{i}"/>' for i in range(n_links)]
    for j in joints:
        body = [
            f'<parent link="{j["parent"]}"/>',
            f'<child link="{j["child"]}"/>',
            f'<origin xyz="{_fmt(j["xyz"])}" rpy="{_fmt(j["rpy"])}"/>',
        ]
        if "axis" in j:
            body.append(f'<axis xyz="{_fmt(j["axis"])}"/>')
        if "limit" in j:
            body.append(f'<limit lower="{j["limit"][0]!r}" upper="{j["limit"][1]!r}" effort="1" velocity="1"/>')
        if "mimic" in j:
            leader, mult, off = j["mimic"]
            body.append(f'<mimic joint="{leader}" multiplier="{mult!r}" offset="{off!r}"/>')
        lines.append(f'  <joint name="{j["name"]}" type="{j["type"]}">{"".join(body)}</joint>')
    lines.append("</robot>")
    return "\n".join(lines)


@st.composite
def tree_and_batch(draw):
    text, joints = draw(trees())
    model = parse_urdf(text)
    n = draw(st.integers(1, 4))
    qs = [[draw(st.floats(-3.0, 3.0)) for _ in range(model.dof)] for _ in range(n)]
    return model, np.array(qs, dtype=float).reshape(n, model.dof)


def _rigid_ok(T: np.ndarray) -> None:
    R = T[..., :3, :3]
    eye = np.broadcast_to(np.eye(3), R.shape)
    assert np.max(np.abs(np.swapaxes(R, -1, -2) @ R - eye)) < ORTHO_TOL
    assert np.max(np.abs(np.linalg.det(R) - 1.0)) < ORTHO_TOL
    assert np.array_equal(T[..., 3, :], np.broadcast_to([0.0, 0.0, 0.0, 1.0], T[..., 3, :].shape))


@PROPERTY_SETTINGS
@given(tree_and_batch())
def test_fk_poses_are_rigid_and_batch_equals_single(case):
    model, Q = case
    poe = compile_model(model)
    T = poe.fk(Q, list(model.links))
    assert T.shape == (len(Q), len(model.links), 4, 4)
    assert np.all(np.isfinite(T))
    _rigid_ok(T)
    for n in range(len(Q)):
        single = poe.fk(Q[n : n + 1], list(model.links))
        np.testing.assert_allclose(single[0], T[n], rtol=0, atol=1e-14)
    # the root link is the world frame
    assert np.array_equal(T[:, model.links.index(model.root)], np.broadcast_to(np.eye(4), (len(Q), 4, 4)))
    # as_batch of the same values as plain lists gives the same Q
    Q2, is_batch = as_batch(model, Q.tolist())
    assert is_batch and np.array_equal(Q2, Q)


def _fd_twists(poe, q: np.ndarray, link: str) -> dict[str, np.ndarray]:
    """Finite-difference Jacobians (6, dof), linear rows first, of ``link`` at q (one batch)."""
    dof = len(q)
    Qp = q + FD_STEP * np.eye(dof)
    Qm = q - FD_STEP * np.eye(dof)
    T = poe.fk(np.vstack([q[None], Qp, Qm]), [link])[:, 0]
    T0, Tp, Tm = T[0], T[1 : dof + 1], T[dof + 1 :]
    R, p = T0[:3, :3], T0[:3, 3]
    out = {r: np.zeros((6, dof)) for r in REFERENCES}
    for k in range(dof):
        dT = (Tp[k] - Tm[k]) / (2 * FD_STEP)
        W = dT[:3, :3] @ R.T  # [w] in world axes
        w = np.array([W[2, 1], W[0, 2], W[1, 0]])
        dp = dT[:3, 3]
        out["world"][:, k] = np.r_[dp - np.cross(w, p), w]
        out["local_world_aligned"][:, k] = np.r_[dp, w]
        out["local"][:, k] = np.r_[R.T @ dp, R.T @ w]
    return out


@PROPERTY_SETTINGS
@given(tree_and_batch())
def test_jacobians_equal_finite_differences_of_fk(case):
    model, Q = case
    poe = compile_model(model)
    for link in model.links:
        J = {r: poe.jacobian(Q, link, r) for r in REFERENCES}
        for r in REFERENCES:
            assert J[r].shape == (len(Q), 6, model.dof)
        for n, q in enumerate(Q):
            fd = _fd_twists(poe, q, link)
            for r in REFERENCES:
                np.testing.assert_allclose(J[r][n], fd[r], rtol=0, atol=FD_TOL, err_msg=f"{link} {r}")


@PROPERTY_SETTINGS
@given(tree_and_batch())
def test_agrees_with_pinocchio(case):
    from kinematics.verify import pinocchio as crosscheck

    model, Q = case
    dev = crosscheck.compare_fk(model, Q)
    assert dev.max_position_error < PINOCCHIO_TOL and dev.max_rotation_error < PINOCCHIO_TOL, dev
    for link in model.links:
        assert crosscheck.compare_jacobian(model, Q, link) < PINOCCHIO_TOL, link


def test_generator_covers_branches_mimic_and_every_joint_type():
    """The strategy really produces what the properties claim to cover (not only chains)."""
    seen_types, branched, mimic = set(), False, False

    @settings(max_examples=MAX_EXAMPLES, deadline=None, derandomize=True)
    @given(trees())
    def collect(tree):
        nonlocal branched, mimic
        _, joints = tree
        seen_types.update(j["type"] for j in joints)
        parents = [j["parent"] for j in joints]
        branched |= len(parents) != len(set(parents))
        mimic |= any("mimic" in j for j in joints)

    collect()
    assert seen_types == set(MOVING) | {"fixed"}
    assert branched and mimic


# --- DH -> URDF -> FK equals the DH product ---------------------------------------------------

def _rot_z(t):
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def _rot_x(t):
    c, s = np.cos(t), np.sin(t)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def _trans(x=0.0, z=0.0):
    T = np.eye(4)
    T[0, 3], T[2, 3] = x, z
    return T


def _pose(xyz, rpy):
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    T = np.eye(4)
    T[:3, :3] = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
    T[:3, 3] = xyz
    return T


@st.composite
def dh_tables(draw):
    convention = draw(st.sampled_from(["standard", "modified"]))
    n = draw(st.integers(1, 6))
    rows = []
    for i in range(n):
        kind = draw(st.sampled_from(["revolute", "prismatic"]))
        rows.append(
            {
                "type": kind,
                "a": draw(coord),
                "alpha": draw(angle),
                "d": draw(coord),
                "theta": draw(angle),
                "name": f"q{i + 1}",
            }
        )
    base = _pose([draw(coord) for _ in range(3)], [draw(angle) for _ in range(3)])
    tool = _pose([draw(coord) for _ in range(3)], [draw(angle) for _ in range(3)])
    table = {"name": "random_dh", "convention": convention, "angles": "radians", "joints": rows,
             "base": base.tolist(), "tool": tool.tolist()}
    q = np.array([draw(st.floats(-3.0, 3.0)) for _ in range(n)])
    return table, q


def _dh_product(table: dict, q: np.ndarray) -> list[np.ndarray]:
    """[T_world_frame_i for i = 1..n] + [T_world_tool], straight from the formulas of docs/design.md."""
    T = np.array(table["base"], dtype=float)
    frames = []
    for row, qi in zip(table["joints"], q):
        theta = row["theta"] + (qi if row["type"] == "revolute" else 0.0)
        d = row["d"] + (qi if row["type"] == "prismatic" else 0.0)
        if table["convention"] == "standard":
            A = _rot_z(theta) @ _trans(z=d) @ _trans(x=row["a"]) @ _rot_x(row["alpha"])
        else:
            A = _rot_x(row["alpha"]) @ _trans(x=row["a"]) @ _rot_z(theta) @ _trans(z=d)
        T = T @ A
        frames.append(T)
    frames.append(T @ np.array(table["tool"], dtype=float))
    return frames


@PROPERTY_SETTINGS
@given(dh_tables())
def test_dh_to_urdf_fk_equals_dh_product(case):
    table_dict, q = case
    table = dh.table_from_dict(table_dict)
    model = parse_urdf(dh.table_to_urdf(table))
    assert model.dof == len(q)
    expected = _dh_product(table_dict, q)
    # the library's own DH product agrees with the formulas
    ours = dh_transforms(table, q[None])[0]
    np.testing.assert_allclose(ours, np.array(expected[:-1]), rtol=0, atol=DH_TOL)
    np.testing.assert_allclose(dh_tool_pose(table, q[None])[0], expected[-1], rtol=0, atol=DH_TOL)
    # FK of the generated URDF: some link carries each DH frame, and one the tool
    T = compile_model(model).fk(q[None], list(model.links))[0]
    for i, E in enumerate(expected):
        hits = [l for k, l in enumerate(model.links) if np.max(np.abs(T[k] - E)) < DH_TOL]
        assert hits, f"no link of the generated URDF has DH frame {i + 1 if i < len(q) else 'tool'}"
