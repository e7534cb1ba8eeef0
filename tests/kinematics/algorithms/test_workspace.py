"""Workspace sampling (algorithms/workspace.py, engine/workspace.py, api.workspace) against closed
forms: the annulus of a planar 2R arm, the box of a Cartesian (3-prismatic) arm, the reach of
the UR5; the manipulability against the Jacobians; seeds, budgets and refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kinematics import api, compile_model, parse_urdf
from kinematics.algorithms import workspace as W
from kinematics.algorithms.measures import conditioning
from kinematics.errors import BudgetError, KinematicsError

#: the annulus area within this fraction at the default resolution
AREA_TOLERANCE = 0.01
#: a box (its faces on the grid) within this fraction
BOX_TOLERANCE = 0.002


def planar_2r(l1: float, l2: float, continuous: bool) -> str:
    limit = "" if continuous else '<limit lower="-3.141592653589793" upper="3.141592653589793" effort="1" velocity="1"/>'
    kind = "continuous" if continuous else "revolute"
    return f"""<robot name="r2"><link name="base"/><link name="upper"/><link name="fore"/><link name="tool"/>
  <joint name="shoulder" type="{kind}"><parent link="base"/><child link="upper"/><axis xyz="0 0 1"/>{limit}</joint>
  <joint name="elbow" type="{kind}"><parent link="upper"/><child link="fore"/><origin xyz="{l1} 0 0"/>
    <axis xyz="0 0 1"/>{limit}</joint>
  <joint name="tip" type="fixed"><parent link="fore"/><child link="tool"/><origin xyz="{l2} 0 0"/></joint>
</robot>"""


def cartesian(a: float, b: float, c: float, offset=(0.1, -0.2, 0.3)) -> str:
    """Three prismatic joints along x, y, z: the carriage sweeps the box offset + [0, a] x [-0.1, b - 0.1] x [0, c]."""
    return f"""<robot name="xyz"><link name="base"/><link name="x"/><link name="y"/><link name="carriage"/>
  <joint name="jx" type="prismatic"><parent link="base"/><child link="x"/><origin xyz="{offset[0]} {offset[1]} {offset[2]}"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="{a}" effort="1" velocity="1"/></joint>
  <joint name="jy" type="prismatic"><parent link="x"/><child link="y"/><axis xyz="0 1 0"/>
    <limit lower="-0.1" upper="{b - 0.1}" effort="1" velocity="1"/></joint>
  <joint name="jz" type="prismatic"><parent link="y"/><child link="carriage"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="{c}" effort="1" velocity="1"/></joint>
</robot>"""


@pytest.mark.parametrize("l1, l2", [(0.5, 0.4), (1.0, 0.3), (0.4, 0.4), (0.3, 0.7)])
@pytest.mark.parametrize("continuous", [True, False])
def test_planar_2r_annulus_area_at_default_resolution(l1, l2, continuous):
    model = parse_urdf(planar_2r(l1, l2, continuous))
    ws = api.workspace(model, "tool")
    exact = math.pi * ((l1 + l2) ** 2 - (l1 - l2) ** 2)
    assert ws.samples == W.DEFAULT_SAMPLES
    assert ws.dimension == 2 and ws.planar and ws.volume == 0.0
    assert abs(ws.area / exact - 1) <= AREA_TOLERANCE, (ws.area, exact)
    assert ws.reach == pytest.approx(l1 + l2, abs=1e-3) and ws.reach <= l1 + l2 + 1e-12
    np.testing.assert_allclose(ws.bounding_box, [[-(l1 + l2), -(l1 + l2), 0], [l1 + l2, l1 + l2, 0]], atol=2e-3)
    assert [n for n, _ in ws.convergence] == [ws.samples // 4, ws.samples // 2, ws.samples]
    assert ws.convergence[-1][1] == ws.area
    assert abs(ws.convergence[1][1] / ws.area - 1) <= 0.02  # converged: N/2 agrees with N
    assert ws.cell[2] == 0.0 and ws.cell[0] <= ws.voxel and ws.cell[1] <= ws.voxel


@pytest.mark.parametrize("dims", [(0.5, 0.4, 0.3), (0.37, 0.81, 0.23)])
def test_cartesian_arm_box_volume(dims):
    a, b, c = dims
    model = parse_urdf(cartesian(a, b, c))
    ws = api.workspace(model, "carriage")
    assert ws.dimension == 3 and ws.area is None
    assert abs(ws.volume / (a * b * c) - 1) <= BOX_TOLERANCE, (ws.volume, a * b * c)
    np.testing.assert_allclose(ws.bounding_box, [[0.1, -0.3, 0.3], [0.1 + a, b - 0.3, 0.3 + c]], atol=5e-3)
    # a point on the carriage: the same box, shifted
    shifted = api.workspace(model, "carriage", point=[0.0, 0.0, 0.5], samples=20_000)
    np.testing.assert_allclose(shifted.bounding_box[:, 2], [0.8, 0.8 + c], atol=0.02)


def test_ur5_tool0_reach_bound(catalogue):
    """The reach is at most the sum of the distances between consecutive link origins on the path
    (each is rigid: the joints are revolute, their child link's origin on their axis frame) and
    at least the distance of the stretched-up arm."""
    model = catalogue.get("ur5")
    ws = api.workspace(model, "tool0")
    poe = compile_model(model)
    path = ["base_link"] + [j.child for j in model.path_joints("tool0")]
    origins = poe.fk(np.zeros((1, 6)), path)[0, :, :3, 3]
    bound = float(np.linalg.norm(np.diff(origins, axis=0), axis=1).sum())
    up = poe.fk(np.array([[0.0, -math.pi / 2, 0.0, -math.pi / 2, 0.0, 0.0]]), ["tool0"])[0, 0, :3, 3]
    assert np.linalg.norm(up) <= ws.reach <= bound
    assert ws.reach >= 0.99 * np.linalg.norm(up)
    assert np.max(np.linalg.norm(ws.points, axis=1)) == ws.reach
    assert ws.dimension == 3 and ws.volume > 0


def test_manipulability_is_the_product_of_singular_values(catalogue, rng):
    for model_id, link in (("ur5", "tool0"), ("panda", "panda_link8"), ("scara", "tool"), ("planar_3r", "tool")):
        model = catalogue.get(model_id)
        poe = compile_model(model)
        li = int(poe.link_indices([link])[0])
        cols = poe.kernel.path_columns(li)
        Q = model.sample_configurations(300, rng)
        from kinematics.engine.workspace import MEASURE_POSE, MEASURE_POSITION, sample_frame

        for measure, rows in ((MEASURE_POSE, slice(0, 6)), (MEASURE_POSITION, slice(0, 3))):
            P, M = sample_frame(poe.kernel, Q, li, measure=measure)
            J = poe.jacobian(Q, link, "local_world_aligned")[:, rows][:, :, cols]
            expected = conditioning(J)["manipulability"]
            np.testing.assert_allclose(M, expected, rtol=1e-9, atol=1e-14)
            np.testing.assert_array_equal(P, poe.fk(Q, [link])[:, 0, :3, 3])


def test_planar_2r_position_manipulability_closed_form():
    """The 2R arm's position manipulability is l1 l2 |sin q2|: at most 0.2 for (0.5, 0.4)."""
    model = parse_urdf(planar_2r(0.5, 0.4, True))
    ws = api.workspace(model, "tool", samples=50_000, measure="position")
    assert ws.manipulability.max() == pytest.approx(0.2, rel=1e-3)
    assert ws.manipulability.max() <= 0.2 + 1e-15
    assert ws.measure == "position"


def test_dexterity_map_is_the_best_per_cell(catalogue):
    ws = api.workspace(catalogue.get("ur5"), "tool0", samples=20_000, voxel=0.1)
    assert ws.voxel == 0.1 and np.all(ws.cell <= 0.1)
    lo = ws.origin
    idx = np.floor((ws.points - lo) / ws.cell).astype(int)
    idx = np.minimum(idx, ws.voxel_index.max(axis=0))
    for k in (0, len(ws.voxel_index) // 2, len(ws.voxel_index) - 1):
        inside = np.all(idx == ws.voxel_index[k], axis=1)
        assert inside.any()
        assert ws.voxel_manipulability[k] == ws.manipulability[inside].max()
        np.testing.assert_allclose(ws.voxel_centers[k], lo + (ws.voxel_index[k] + 0.5) * ws.cell)
    assert len(np.unique(ws.voxel_index, axis=0)) == len(ws.voxel_index)


def test_seeds_prefixes_and_progress(catalogue):
    model = catalogue.get("panda")
    a = api.workspace(model, "panda_link8", samples=70_000, random_seed=3)
    b = api.workspace(model, "panda_link8", samples=1000, random_seed=3)
    c = api.workspace(model, "panda_link8", samples=1000, random_seed=4)
    np.testing.assert_array_equal(a.points[:1000], b.points)  # the first N samples of a larger run
    assert not np.array_equal(b.points, c.points)
    seen = []
    W.sample_workspace(model, "panda_link8", 70_000, progress=seen.append)
    assert seen == [W.CHUNK, 70_000 - W.CHUNK]  # chunked: memory bounded by a chunk of configurations


def test_a_link_no_joint_moves_is_a_point(catalogue):
    model = catalogue.get("ur5")
    ws = api.workspace(model, "base_link", samples=100)
    assert ws.dimension == 0 and ws.volume == 0.0 and ws.area == 0.0
    assert np.all(ws.manipulability == 1.0)


def test_refusals_and_budget(catalogue):
    model = catalogue.get("ur5")
    with pytest.raises(BudgetError) as exc:
        api.workspace(model, samples=1001, budget=api.Budget(max_workspace_samples=1000))
    assert exc.value.budget == "workspace-samples"
    with pytest.raises(KinematicsError, match="samples"):
        api.workspace(model, samples=0)
    with pytest.raises(KinematicsError, match="voxel"):
        api.workspace(model, samples=100, voxel=-1.0)
    with pytest.raises(KinematicsError, match="give a larger voxel"):
        api.workspace(model, samples=100, voxel=1e-9)
    with pytest.raises(KinematicsError, match="measure"):
        api.workspace(model, samples=100, measure="speed")
    unlimited = parse_urdf(cartesian(1, 1, 1).replace('<limit lower="0" upper="1" effort="1" velocity="1"/>', "", 1))
    if np.isfinite(unlimited.upper_limits).all():
        pytest.skip("the parser gives unlimited prismatic joints a default range")
    with pytest.raises(KinematicsError, match="prismatic without limits"):
        api.workspace(unlimited, "carriage", samples=100)


def test_tiny_voxel_and_few_samples_found_by_the_fuzzer():
    """Two 500s schemathesis found (issue 18): a voxel so small that the cell count overflows a float
    (now a KinematicsError naming the voxel), and fewer than three samples (the cloud's axes)."""
    from kinematics import default_catalogue

    ur5 = default_catalogue().get("ur5")
    with pytest.raises(KinematicsError, match="voxel"):
        api.workspace(ur5, samples=100, voxel=5e-324)
    hand = default_catalogue().get("allegro_left_hand")
    for n, dim in ((1, 0), (2, 1), (3, 2)):
        ws = api.workspace(hand, samples=n)
        assert ws.dimension == dim and ws.samples == n


@pytest.mark.parametrize("model_id, link", [("ur5", "tool0"), ("panda", "panda_hand"), ("puma560_standard", None),
                                            ("ur5_dh", None)])
def test_fine_voxels_never_fall_below_the_occupied_cells(catalogue, model_id, link):
    """A voxel too fine for the samples (most samples alone in their cell) used to extrapolate the
    volume to 0 (2 V(h) - V(2h) with V(2h) near 8 V(h)). Now the estimate is the occupied cells'
    volume, not converged, with the advice to give a larger voxel or more samples; from coarse to
    fine voxels no estimate is 0 or below half the occupied volume."""
    model = catalogue.get(model_id)
    link = link or model.leaf_links[0]
    P, M = W.sample_workspace(model, link, 100_000, random_seed=7)
    for voxel in (0.15, 0.1, 0.05, 0.03, 0.02, 0.01):
        ws = W.analyse(P, M, voxel=voxel)
        occupied = len(ws.voxel_centers) * float(np.prod(ws.cell))
        assert ws.occupied == pytest.approx(occupied, rel=1e-12)
        assert ws.dimension == 3 and ws.volume > 0
        assert ws.volume >= 0.5 * occupied
        assert [v > 0 for _, v in ws.convergence] == [True] * 3
        assert ws.converged == (ws.advice is None)
        if ws.samples < W.MIN_SAMPLES_PER_CELL * len(ws.voxel_centers):  # sparse: what the samples show, and said so
            assert ws.volume == occupied and not ws.converged
            assert "too sparse" in ws.advice and "larger voxels" in ws.advice and "more samples" in ws.advice
    fine = W.analyse(P, M, voxel=0.02)
    assert fine.samples / len(fine.voxel_centers) < 2 and fine.volume == fine.occupied
    assert [v for _, v in fine.convergence] == sorted(v for _, v in fine.convergence)  # still growing: not converged


def test_sparse_box_is_a_lower_bound_and_a_dense_one_exact():
    """A Cartesian arm sweeps a box whose faces lie on the grid: every occupied cell lies inside it,
    so with a voxel too fine for the samples the estimate (the occupied cells) is below the box and
    above 0; with cells the samples fill it is the box, converged."""
    a, b, c = 0.5, 0.4, 0.3
    model = parse_urdf(cartesian(a, b, c))
    sparse = api.workspace(model, "carriage", samples=20_000, voxel=0.02)  # 2.7 samples per cell of the box
    assert 0.5 * a * b * c < sparse.volume <= a * b * c
    assert sparse.volume == sparse.occupied and not sparse.converged and "too sparse" in sparse.advice
    dense = api.workspace(model, "carriage", samples=20_000, voxel=0.05)
    assert dense.converged and dense.advice is None
    assert dense.volume == pytest.approx(a * b * c, rel=BOX_TOLERANCE)


def test_converged_answers_have_no_advice_and_a_drifting_estimate_says_so(catalogue):
    ws = api.workspace(parse_urdf(planar_2r(0.5, 0.4, True)), "tool")
    assert ws.converged and ws.advice is None
    drifting = W._verdict(1000, 0.1, 3, (10, 1.0, 1.2), True, 0.8, 1.0, None)
    assert drifting[0] is False and "changes by 20.0%" in drifting[1] and "more samples" in drifting[1]


def test_a_planar_arm_with_a_fine_voxel_answers_the_occupied_area():
    model = parse_urdf(planar_2r(0.5, 0.4, True))
    exact = math.pi * (0.9**2 - 0.1**2)
    ws = api.workspace(model, "tool", samples=20_000, voxel=0.002)  # 630,000 cells in the annulus
    assert ws.dimension == 2 and ws.volume == 0.0
    assert ws.area == ws.occupied == pytest.approx(len(ws.voxel_centers) * ws.cell[0] * ws.cell[1], rel=1e-12)
    assert 0 < ws.area < exact and not ws.converged and "area is that of the occupied cells" in ws.advice


def test_the_interior_floor_is_the_cells_the_samples_enclose():
    """A dense cube of cells: the enclosed ones are those with all six face neighbours occupied,
    counted from the sample that completes the neighbourhood."""
    g = W._Grid(np.zeros(3), np.eye(3), np.array([6, 6, 6]), np.full(3, 1 / 6), 3)
    idx = np.array([(i, j, k) for i in range(6) for j in range(6) for k in range(6)])
    first = np.arange(len(idx))[::-1].copy()  # the last cell's sample came first
    enclosed = W._enclosed_from(idx, first, g)
    inner = np.all((idx >= 1) & (idx <= 4), axis=1)
    assert np.all(enclosed[~inner] == np.iinfo(np.int64).max)
    for c in np.flatnonzero(inner)[:10]:
        neighbours = [c] + [int(np.flatnonzero(np.all(idx == idx[c] + d, axis=1))[0])
                            for d in np.vstack([np.eye(3, dtype=int), -np.eye(3, dtype=int)])]
        assert enclosed[c] == first[neighbours].max()
