"""Every IK solution (kinematics.algorithms.ik_all, ik_families): the family of each catalogue
robot and preset, the generating configuration always among the solutions, every listed solution
exact against Pinocchio's FK, calibrated robots as complete as nominal ones, a general 6R against a
multistart search, singular and unreachable targets, limits respect vs ignore, locked joints."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import api, compile_model, default_catalogue
from kinematics.algorithms.ik import inverse_kinematics, pose_errors
from kinematics.algorithms import ik_all
from kinematics.algorithms.calibration.synthetic import moved_origins
from kinematics.algorithms.ik_all import all_solutions
from kinematics.algorithms.ik_families import detect, reduce_chain
from kinematics.errors import LockedJointError
from kinematics.io.dh_table import model_from_table, table_from_dict
from kinematics.spatial.transforms import exp_screws
from kinematics.verify.pinocchio import reference_for

EXACT = 1e-9

#: (model, link, locked, family)
ROBOTS = [
    ("ur5", "tool0", None, "three_parallel"),
    ("ur10", "tool0", None, "three_parallel"),
    ("puma560_standard", "tool", None, "spherical_wrist_parallel_23"),
    ("puma560_modified", "tool", None, "spherical_wrist_parallel_23"),
    ("kuka_kr5_sixx", "tool", None, "spherical_wrist_parallel_23"),
    ("stanford_arm", "tool", None, "spherical_wrist_intersecting_12_prismatic"),
    ("panda", "panda_link8", {"panda_joint7": 0.4}, "spherical_shoulder_intersecting_12"),
    ("kuka_lwr4", "tool", {"joint_3": -0.3}, "spherical_wrist_intersecting_12"),
]


@pytest.fixture(scope="module")
def catalogue():
    return default_catalogue()


def _targets(model, link, n, seed, locked=None):
    Q = model.sample_configurations(n, np.random.default_rng(seed), continuous_range=np.pi)
    for name, v in (locked or {}).items():
        Q[:, model.q_index[name]] = v
    return Q, compile_model(model).fk(Q, [link])[:, 0]


def _angle_distance(A, b, columns):
    d = A[:, columns] - b[columns]
    return np.abs(np.mod(d + np.pi, 2 * np.pi) - np.pi).max(axis=1)


def _contains(sol, n, q, columns):
    qs = sol.q[n, :sol.count[n]]
    return len(qs) > 0 and _angle_distance(qs, q, columns).min() < 1e-7


def _pinocchio_exact(model, link, sol, T):
    ref = reference_for(model)
    for n in range(len(T)):
        for k in range(sol.count[n]):
            theirs = ref.poses(sol.q[n, k])[link][None]
            p, r = pose_errors(theirs, T[n:n + 1])
            assert p[0] < EXACT and r[0] < EXACT, (n, k, p, r)


@pytest.mark.parametrize("model_id, link, locked, family", ROBOTS)
def test_family_and_every_solution(catalogue, model_id, link, locked, family):
    model = catalogue.get(model_id)
    fam = detect(reduce_chain(model, link, locked))
    assert (fam.name, fam.closed_form, fam.near, fam.max_solutions) == (family, True, False, 8)
    Q, T = _targets(model, link, 200, seed=1, locked=locked)
    sol = all_solutions(model, link, T, locked=locked, limits="ignore")
    assert sol.method == "analytic"
    chain = reduce_chain(model, link, locked)
    for n in range(len(Q)):
        assert _contains(sol, n, Q[n], chain.columns), f"target {n}: the generating configuration is missing"
    assert sol.count.max() <= 8
    listed = sol.q[~np.isnan(sol.q[..., 0])]
    assert np.all(np.isfinite(listed))
    # locked joints keep their values in every solution
    for name, v in (locked or {}).items():
        assert np.all(listed[:, model.q_index[name]] == v)
    _pinocchio_exact(model, link, sol, T[:15])


@pytest.mark.parametrize("model_id, link", [("puma560_standard", "tool"), ("ur5", "tool0")])
def test_the_search_finds_nothing_the_closed_form_misses(catalogue, model_id, link):
    model = catalogue.get(model_id)
    _, T = _targets(model, link, 4, seed=3)
    closed = all_solutions(model, link, T, limits="ignore")
    search = all_solutions(model, link, T, limits="ignore", method="numeric", search_seeds=2048)
    assert search.method == "search"
    cols = np.arange(6)
    for n in range(len(T)):
        for q in search.q[n, :search.count[n]]:
            assert _contains(closed, n, q, cols)


def _general_6r():
    """A 6R arm from a random DH table (no two axes parallel or meeting): no closed form here."""
    rng = np.random.default_rng(42)
    rows = [{"type": "revolute", "a": float(rng.uniform(0.1, 0.4)), "alpha": float(rng.uniform(0.3, 1.3)),
             "d": float(rng.uniform(0.05, 0.3)), "theta": 0.0, "limits": [-3.1, 3.1]} for _ in range(6)]
    return model_from_table(table_from_dict({"name": "general_6r", "convention": "standard", "joints": rows}))


def test_general_6r_search_finds_everything_a_multistart_finds():
    model = _general_6r()
    link = model.leaf_links[0]
    assert detect(reduce_chain(model, link)).name == "general_6r"  # solved by the elimination by default
    Q, T = _targets(model, link, 2, seed=5)
    ours = all_solutions(model, link, T, limits="ignore", method="numeric")
    assert ours.method == "search"
    cols = np.arange(6)
    for n in range(len(T)):
        assert _contains(ours, n, Q[n], cols)
        # today's solver from 150 random seeds: every solution it reaches is one of ours
        seeds = model.sample_configurations(150, np.random.default_rng(n))
        theirs = inverse_kinematics(model, link, np.repeat(T[n:n + 1], len(seeds), 0), seeds, restarts=0,
                                    position_tolerance=1e-9, rotation_tolerance=1e-9)
        for q in theirs.q[theirs.success]:
            assert _contains(ours, n, q, cols), q
    _pinocchio_exact(model, link, ours, T)


def test_a_calibrated_ur5_gets_every_solution(catalogue):
    model = moved_origins(catalogue.get("ur5"), seed=3)
    fam = detect(reduce_chain(model, "tool0"))
    assert fam.name == "three_parallel" and fam.near and fam.closed_form and 1e-4 < fam.deviation < 1e-2
    Q, T = _targets(model, "tool0", 300, seed=2)
    sol = all_solutions(model, "tool0", T, limits="ignore")
    cols = np.arange(6)
    missing = [n for n in range(len(Q)) if not _contains(sol, n, Q[n], cols)]
    assert not missing
    p, r = pose_errors(compile_model(model).fk(np.nan_to_num(sol.q.reshape(-1, 6)), ["tool0"])[:, 0],
                       np.repeat(T, sol.q.shape[1], 0))
    listed = ~np.isnan(sol.q[..., 0]).reshape(-1)
    assert p[listed].max() < EXACT and r[listed].max() < EXACT
    # the same set as a dense search on the real model, for targets away from the edges
    search = all_solutions(model, "tool0", T[:8], limits="ignore", method="numeric", search_seeds=2048)
    for n in range(8):
        if sol.complete[n]:
            assert search.count[n] <= sol.count[n]
            for q in search.q[n, :search.count[n]]:
                assert _contains(sol, n, q, cols)


def test_wens_rhino_arm_in_closed_form(catalogue):
    """A slide, then axes 3 ∥ 4 ∥ 5 between two others: four solutions of a generic pose by subproblems
    2, 1, a linear equation for the slide, 3 and 1; the same as a dense search; where the pose does not
    fix the slide (q2 = 0), representatives flagged singular."""
    model = catalogue.get("rhino")
    fam = detect(reduce_chain(model, "tool"))
    assert (fam.name, fam.closed_form, fam.max_solutions) == ("prismatic_three_parallel", True, 4)
    Q, T = _targets(model, "tool", 40, seed=4)
    sol = all_solutions(model, "tool", T, limits="ignore")
    assert sol.method == "analytic" and (sol.count == 4).all()
    cols = np.arange(6)
    for n in range(len(Q)):
        assert _contains(sol, n, Q[n], cols)
    dense = all_solutions(model, "tool", T[:4], limits="ignore", method="numeric", search_seeds=2048,
                          position_tolerance=1e-9, rotation_tolerance=1e-9)
    for n in range(4):
        assert dense.count[n] == 4
        for q in dense.q[n, :dense.count[n]]:
            assert _contains(sol, n, q, cols)
    _pinocchio_exact(model, "tool", sol, T[:5])
    q = Q[0].copy()
    q[1] = 0.0
    one = all_solutions(model, "tool", compile_model(model).fk(q[None], ["tool"])[:, 0], limits="ignore")
    assert one.count[0] >= 1 and one.singular[0, :one.count[0]].all()


def test_a_calibrated_ur5_where_a_branch_is_lost_gets_every_exact_solution(catalogue):
    """Targets where the polish of the ideal chain's closed form finds fewer solutions than the ideal
    chain has: the elimination of the real chain (or the search, where it is not trusted) lists every
    exact solution a dense search finds."""
    model = moved_origins(catalogue.get("ur5"), seed=3)
    Q, T = _targets(model, "tool0", 600, seed=2026)
    chain, fam, real = ik_all._chain_family(model, "tool0", None, None)
    problem = ik_all._Problem(model, compile_model(model), "tool0", None, chain, fam, real, T, np.zeros((len(T), 6)),
                              None, "pose", (1e-6, 1e-6), ik_all.SEARCH_SEEDS)
    _, found, *_, nominal, _ = ik_all._closed_form_solutions(problem)
    short = np.flatnonzero(found < nominal)[:6]
    assert short.size >= 2, "the calibration must move some targets across a branch point"
    sol = all_solutions(model, "tool0", T[short], limits="ignore")
    assert (sol.count > found[short]).any()  # the elimination found branches the polish had lost
    dense = all_solutions(model, "tool0", T[short], limits="ignore", method="numeric", search_seeds=2048,
                          position_tolerance=1e-9, rotation_tolerance=1e-9)
    cols = np.arange(6)
    for i in range(len(short)):
        assert _contains(sol, i, Q[short[i]], cols)
        for q in dense.q[i, :dense.count[i]]:
            assert _contains(sol, i, q, cols)


def test_singular_targets_give_flagged_representatives(catalogue):
    model = catalogue.get("ur5")
    q = np.array([0.3, -1.0, 1.2, -0.5, 0.0, 0.2])  # wrist 2 at zero: axes 4 and 6 parallel
    T = compile_model(model).fk(q[None], ["tool0"])[:, 0]
    sol = all_solutions(model, "tool0", T, limits="ignore")
    k = sol.count[0]
    assert k >= 1 and np.all(np.isfinite(sol.q[0, :k])) and sol.singular[0, :k].any()
    assert np.all(sol.position_error[0, :k] < EXACT)
    puma = catalogue.get("puma560_standard")
    q = np.array([0.2, 0.3, -0.4, 0.5, 0.0, 0.1])
    T = compile_model(puma).fk(q[None], ["tool"])[:, 0]
    sol = all_solutions(puma, "tool", T, limits="ignore")
    k = sol.count[0]
    assert 1 <= k < 8  # the two wrist branches of the generating arm posture are one continuum here
    mine = np.argmin(_angle_distance(sol.q[0, :k], q, np.array([0, 1, 2])))
    assert sol.singular[0, mine] and np.all(np.isfinite(sol.q[0, :k]))


def test_unreachable_targets_have_no_solutions(catalogue):
    model = catalogue.get("ur5")
    T = np.eye(4)[None].copy()
    T[0, :3, 3] = [3.0, 0.0, 0.0]
    for method in ("auto", "numeric"):
        sol = all_solutions(model, "tool0", T, method=method)
        assert sol.count[0] == 0 and sol.q.shape == (1, 0, 6)


def test_respect_lists_every_copy_ignore_each_branch_once(catalogue):
    model = catalogue.get("ur5")
    _, T = _targets(model, "tool0", 3, seed=9)
    ign = all_solutions(model, "tool0", T, limits="ignore")
    res = all_solutions(model, "tool0", T, limits="respect")
    lo, hi = model.lower_limits, model.upper_limits
    for n in range(3):
        branches = ign.q[n, :ign.count[n]]
        assert np.all(np.abs(branches) <= np.pi)
        expected = 0
        for b in branches:
            copies = 1
            for j in range(6):
                ks = [k for k in range(-3, 4) if lo[j] - 1e-12 <= b[j] + 2 * np.pi * k <= hi[j] + 1e-12]
                copies *= len(ks)
            expected += copies
        assert res.count[n] == expected and expected > ign.count[n]
        listed = res.q[n, :res.count[n]]
        assert np.all((listed >= lo - 1e-12) & (listed <= hi + 1e-12)) and res.within_limits[n, :res.count[n]].all()
        assert len({tuple(np.round(q, 9)) for q in listed}) == len(listed)


def test_ignore_flags_branches_outside_the_limits(catalogue):
    model = catalogue.get("puma560_standard")
    _, T = _targets(model, "tool", 10, seed=4)
    ign = all_solutions(model, "tool", T, limits="ignore")
    res = all_solutions(model, "tool", T, limits="respect")
    assert not ign.within_limits[ign.count[:, None] > np.arange(ign.q.shape[1])].all()  # Puma's limits cut branches
    cols = np.arange(6)
    for n in range(10):
        for k in range(ign.count[n]):
            if ign.within_limits[n, k]:
                assert np.abs(res.q[n, :res.count[n]] - ign.q[n, k]).max(axis=1).min() < 1e-12
        for q in res.q[n, :res.count[n]]:  # every listed copy is a copy of a branch
            assert _contains(ign, n, q, cols)


def test_batch_equals_single(catalogue):
    model = catalogue.get("kuka_kr5_sixx")
    _, T = _targets(model, "tool", 6, seed=8)
    batch = all_solutions(model, "tool", T)
    for n in range(6):
        one = all_solutions(model, "tool", T[n:n + 1])
        k = one.count[0]
        assert batch.count[n] == k
        np.testing.assert_array_equal(batch.q[n, :k], one.q[0, :k])


def test_locked_validation(catalogue):
    panda = catalogue.get("panda")
    with pytest.raises(LockedJointError, match="panda_joint9") as e:
        reduce_chain(panda, "panda_link8", {"panda_joint9": 0.1})
    assert e.value.joint == "panda_joint9"
    with pytest.raises(LockedJointError, match="panda_joint7.*outside"):
        reduce_chain(panda, "panda_link8", {"panda_joint7": 4.0})
    with pytest.raises(LockedJointError, match="not a number"):
        reduce_chain(panda, "panda_link8", {"panda_joint7": "x"})
    # unlocked, the 7-dof chain has infinitely many solutions
    with pytest.raises(Exception, match="infinitely many"):
        all_solutions(panda, "panda_link8", np.eye(4)[None])


def test_api_answer_and_seed_order(catalogue):
    model = catalogue.get("ur5")
    q = np.array([0.3, -1.0, 1.2, -0.5, 0.8, 0.2])
    T = api.fk(model, q, links=["tool0"]).poses[0, 0]
    a = api.ik(model, T, link="tool0", solutions="all", limits="ignore", seed=q, verify=True)
    assert a.family == "three_parallel" and a.method == "analytic" and a.q.shape == (1, 8, 6)
    np.testing.assert_allclose(a.q[0, 0], q, atol=1e-9)  # nearest the seed first
    assert a.verification["max_position_error"] < EXACT
    assert len(a.solutions(0)) == 8 and set(a.solutions(0)[0]) == {"q", "position_error", "rotation_error",
                                                                     "within_limits", "singular"}
    one = api.ik(model, T, link="tool0", method="analytic", seed=q + 0.01)
    np.testing.assert_allclose(one.solution.q[0], q, atol=1e-9)
    assert api.ik_family(catalogue.get("panda"), link="panda_link8", locked={"panda_joint7": 0.0})["closed_form"]


@pytest.mark.parametrize("model_id, mode, family, count", [
    ("planar_2r", "position", "planar", 2),  # elbow up and down
    ("planar_3r", "pose", "planar", 2),
    ("scara", "pose", "planar", 2),
    ("rpr_example", "pose", "rpr", 1),
])
def test_short_chains_every_solution_by_search(catalogue, model_id, mode, family, count):
    """The search (``method: "numeric"``) on the short chains (their closed forms: test_ik_general.py)."""
    model = catalogue.get(model_id)
    link = model.leaf_links[0]
    assert detect(reduce_chain(model, link)).name == family
    Q, T = _targets(model, link, 6, seed=12)
    sol = all_solutions(model, link, T, limits="ignore", mode=mode, method="numeric")
    assert sol.method == "search" and np.all(sol.count == count)
    cols = np.arange(model.dof)
    for n in range(len(Q)):
        assert _contains(sol, n, Q[n], cols)


def test_general_6r_more_seeds_find_nothing_new():
    """The search's 512 seeds against 4,096 on the same targets: the same set (no more than 16)."""
    model = _general_6r()
    link = model.leaf_links[0]
    _, T = _targets(model, link, 2, seed=21)
    ours = all_solutions(model, link, T, limits="ignore", method="numeric")
    dense = all_solutions(model, link, T, limits="ignore", method="numeric", search_seeds=4096)
    cols = np.arange(6)
    assert np.all(ours.count <= 16)
    for n in range(len(T)):
        assert dense.count[n] == ours.count[n]
        for q in dense.q[n, :dense.count[n]]:
            assert _contains(ours, n, q, cols)


def test_base_and_tool_on_the_closed_form(catalogue):
    model = catalogue.get("kuka_kr5_sixx")
    base = np.eye(4); base[:3, 3] = [0.3, -0.2, 0.1]
    base[:3, :3] = exp_screws(np.array([[0.0, 0, 1]]), np.zeros((1, 3)), np.array([True]), np.array([0.7]))[0][:3, :3]
    q = np.array([0.2, -0.3, 0.4, 0.5, -0.6, 0.7])
    a = api.ik(model, np.eye(4), link="tool", solutions="all")  # warm; any answer
    base = base.tolist()
    T = api.fk(model, q, links=["tool"], base=base, point=[0.0, 0.05, 0.1]).poses[0, 0]
    a = api.ik(model, T, link="tool", solutions="all", limits="ignore", base=base, point=[0.0, 0.05, 0.1], verify=True)
    assert a.method == "analytic" and _contains(a, 0, q, np.arange(6))
    assert a.verification["max_position_error"] < EXACT


def test_position_mode_of_a_six_joint_chain_is_refused(catalogue):
    with pytest.raises(Exception, match="infinitely many"):
        all_solutions(catalogue.get("ur5"), "tool0", np.eye(4)[None], mode="position")


def _wrist_on_a_general_arm():
    """A spherical wrist on a 3R arm from a random DH table (no two of its axes parallel or meeting)."""
    rng = np.random.default_rng(8)
    rows = [{"type": "revolute", "a": float(rng.uniform(0.1, 0.4)), "alpha": float(rng.uniform(0.4, 1.2)),
             "d": float(rng.uniform(0.05, 0.3)), "theta": 0.0, "limits": [-3.1, 3.1]} for _ in range(3)]
    rows += [{"type": "revolute", "a": 0.0, "alpha": -np.pi / 2, "d": 0.0, "theta": 0.0, "limits": [-3.1, 3.1]},
             {"type": "revolute", "a": 0.0, "alpha": np.pi / 2, "d": 0.0, "theta": 0.0, "limits": [-3.1, 3.1]},
             {"type": "revolute", "a": 0.0, "alpha": 0.0, "d": 0.1, "theta": 0.0, "limits": [-3.1, 3.1]}]
    return model_from_table(table_from_dict({"name": "wrist_general", "convention": "standard", "joints": rows}))


def test_the_bracketing_search_of_a_wrist_on_a_general_arm_finds_each_generating_configuration():
    """The compiled search over q1 (the fallback where the elimination does not apply)."""
    from kinematics.engine import ik_fast
    from kinematics.spatial.transforms import inverse_transform

    model = _wrist_on_a_general_arm()
    link = model.leaf_links[0]
    chain = reduce_chain(model, link)
    fam = detect(chain)
    Q, T = _targets(model, link, 20, seed=6)
    r = chain.r.copy()
    r[3:6] = fam.centre
    G = np.ascontiguousarray(np.einsum("nij,jk->nik", T, inverse_transform(chain.M)))
    cand, count, flag = np.zeros((20, 16, 6)), np.zeros(20, np.int64), np.zeros((20, 16), np.int64)
    ik_fast.spherical_wrist_search(G, np.ascontiguousarray(chain.h), r, np.ascontiguousarray(fam.centre),
                                   ik_fast.SEARCH_SAMPLES, cand, count, flag)
    for n in range(20):
        d = np.abs(np.angle(np.exp(1j * (cand[n, :count[n]] - Q[n])))).max(axis=1)
        assert d.min() < 1e-7


def test_a_spherical_wrist_on_a_general_arm_by_the_elimination():
    model = _wrist_on_a_general_arm()
    link = model.leaf_links[0]
    fam = detect(reduce_chain(model, link))
    assert (fam.name, fam.closed_form, fam.max_solutions, fam.kernel) == ("spherical_wrist_general", True, 8,
                                                                          "general_6r")
    Q, T = _targets(model, link, 60, seed=6)
    sol = all_solutions(model, link, T, limits="ignore")
    assert sol.method == "analytic" and sol.count.max() <= 8
    cols = np.arange(6)
    for n in range(len(Q)):
        assert _contains(sol, n, Q[n], cols)
    # the multistart finds nothing more
    dense = all_solutions(model, link, T[:4], limits="ignore", method="numeric", search_seeds=2048)
    for n in range(4):
        for q in dense.q[n, :dense.count[n]]:
            assert _contains(sol, n, q, cols)
    _pinocchio_exact(model, link, sol, T[:5])
