"""Chains with no subproblem family (kinematics.algorithms.ik_general): the general 6R by the 16-degree
elimination finds every solution a dense multistart finds (today's numerical solver from thousands of
seeds, and the every-solution search), each exact against Pinocchio's FK; the short chains (2R / 3R
planar, SCARA, RPR) in closed form, exact and with the right count."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import compile_model, default_catalogue
from kinematics.algorithms import ik_general
from kinematics.algorithms.ik import inverse_kinematics, pose_errors
from kinematics.algorithms.ik_all import all_solutions
from kinematics.algorithms.ik_families import detect, reduce_chain
from kinematics.io.dh_table import model_from_table, table_from_dict
from kinematics.verify.pinocchio import reference_for

EXACT = 1e-9


def _random_6r(seed: int, convention: str = "standard"):
    """A 6R arm from a random DH table (generic: no two axes parallel or meeting)."""
    rng = np.random.default_rng(seed)
    rows = [{"type": "revolute", "a": float(rng.uniform(0.05, 0.5)), "alpha": float(rng.uniform(-3.0, 3.0)),
             "d": float(rng.uniform(-0.3, 0.3)), "theta": float(rng.uniform(-3.0, 3.0)), "limits": [-3.1, 3.1]}
            for _ in range(6)]
    return model_from_table(table_from_dict({"name": f"random_6r_{seed}", "convention": convention, "joints": rows}))


def _targets(model, link, n, seed):
    Q = model.sample_configurations(n, np.random.default_rng(seed), continuous_range=np.pi)
    return Q, compile_model(model).fk(Q, [link])[:, 0]


def _distance(A, b):
    """Largest joint difference (modulo 2π) of each row of A (K, n) to b (n,)."""
    return np.abs(np.mod(A - b + np.pi, 2 * np.pi) - np.pi).max(axis=1)


def _contains(qs, q):
    return len(qs) > 0 and _distance(qs, q).min() < 1e-7


def _pinocchio_exact(model, link, sol, T, position_only=False):
    ref = reference_for(model)
    for n in range(len(T)):
        for k in range(sol.count[n]):
            p, r = pose_errors(ref.poses(sol.q[n, k])[link][None], T[n:n + 1])
            assert p[0] < EXACT and (position_only or r[0] < EXACT), (n, k, p, r)


@pytest.mark.parametrize("seed, convention", [(100, "modified"), (101, "standard"), (104, "modified"),
                                              (105, "standard")])
def test_general_6r_eigen_finds_everything_a_dense_multistart_finds(seed, convention):
    model = _random_6r(seed, convention)
    link = model.leaf_links[0]
    fam = detect(reduce_chain(model, link))
    assert (fam.name, fam.closed_form, fam.max_solutions, fam.kernel) == ("general_6r", True, 16, "general_6r")
    Q, T = _targets(model, link, 3, seed)
    ours = all_solutions(model, link, T, limits="ignore")
    assert ours.method == "analytic"
    assert np.all(ours.count <= 16) and np.all(ours.count % 2 == 0)  # real roots come in pairs (generic target)
    # the every-solution multistart search with 2,048 seeds
    search = all_solutions(model, link, T, limits="ignore", method="numeric", search_seeds=2048)
    for n in range(len(T)):
        mine = ours.q[n, :ours.count[n]]
        assert _contains(mine, Q[n]), "the generating configuration is missing"
        assert np.all(np.isfinite(mine))
        for q in search.q[n, :search.count[n]]:
            assert _contains(mine, q), (n, q)
        # today's numerical solver from 2,000 random seeds: every solution it converges to is one of ours
        seeds = model.sample_configurations(2000, np.random.default_rng(seed + n))
        theirs = inverse_kinematics(model, link, np.repeat(T[n:n + 1], len(seeds), 0), seeds, restarts=0,
                                    position_tolerance=1e-10, rotation_tolerance=1e-10)
        found = theirs.q[theirs.success]
        assert len(found) > 0
        for q in found:
            assert _contains(mine, q), (n, q)
        # ... and it finds nothing we list that it could not reach: the sets are equal on these targets
        assert search.count[n] == ours.count[n]
    _pinocchio_exact(model, link, ours, T)


def test_general_6r_raw_candidates_are_near_exact_and_include_the_generating_configuration():
    model = _random_6r(42)
    link = model.leaf_links[0]
    chain = reduce_chain(model, link)
    Q, T = _targets(model, link, 20, seed=9)
    cand, count = ik_general.general_6r_candidates(chain, T)
    assert np.all(count >= 0) and np.all(count <= 16)
    for n in range(len(T)):
        assert _distance(cand[n, :count[n]], Q[n]).min() < 1e-6


#: a Jaco-like arm (standard DH alpha, a, d): axes 1, 2 meet, 2 ∥ 3, axes 4, 5, 6 each meeting the
#: next at 60° with no common point
JACO_LIKE = [(np.pi / 2, 0, 0.2755), (np.pi, 0.41, 0), (np.pi / 2, 0, -0.0098), (1.047, 0, -0.2502),
             (1.047, 0, -0.0858), (np.pi, 0, -0.2116)]


def _revolute_table(name, table):
    """A 6R model from standard DH rows (alpha, a, d), every joint within ±3.1 rad."""
    rows = [{"type": "revolute", "alpha": al, "a": a, "d": d, "theta": 0.0, "limits": [-3.1, 3.1]} for al, a, d in table]
    return model_from_table(table_from_dict({"name": name, "convention": "standard", "joints": rows}))


@pytest.mark.parametrize("table, family, reversed_, method", [
    # axes 1 and 2 meet (a1 = 0): the 8 products of q1, q2 are dependent; the reversed chain's are not
    ([(1.2, 0.0, 0.3), (0.4, 0.35, 0.1), (1.0, 0.2, 0.0), (0.8, 0.0, 0.25), (1.3, 0.1, 0.1), (0.5, 0.15, 0.1)],
     "general_6r", True, "analytic"),
    # the Jaco-like arm: degenerate both ways, solved on cyclic shifts of the loop
    (JACO_LIKE, "general_6r", False, "analytic"),
])
def test_a_6r_of_special_geometry_reversed_or_on_shifts_of_the_loop(table, family, reversed_, method):
    """Never a silent empty answer: where the elimination degenerates on the chain it runs on the
    reversed chain, and where it degenerates both ways on cyclic shifts of the loop; the same
    solutions as a dense search."""
    model = _revolute_table("special", table)
    link = model.leaf_links[0]
    fam = detect(reduce_chain(model, link))
    assert (fam.name, fam.reversed) == (family, reversed_)
    Q, T = _targets(model, link, 3, seed=4)
    ours = all_solutions(model, link, T, limits="ignore")
    assert ours.method == method
    search = all_solutions(model, link, T, limits="ignore", method="numeric", search_seeds=2048)
    for n in range(len(T)):
        assert _contains(ours.q[n, :ours.count[n]], Q[n])
        assert search.count[n] == ours.count[n]
        for q in search.q[n, :search.count[n]]:
            assert _contains(ours.q[n, :ours.count[n]], q)
    _pinocchio_exact(model, link, ours, T)


def test_a_jaco_like_arm_is_solved_on_cyclic_shifts_of_the_loop():
    """Degenerate forwards and reversed, the elimination runs per target on a shift of the loop: no
    target is left to the search, and every generating configuration is a candidate."""
    model = _revolute_table("jaco_like", JACO_LIKE)
    link = model.leaf_links[0]
    chain = reduce_chain(model, link)
    assert not ik_general.usable(chain) and not ik_general.usable(chain.reversed())
    Q, T = _targets(model, link, 30, seed=9)
    cand, count = ik_general.general_6r_candidates(chain, T)
    assert (count >= 0).all()
    for n in range(len(T)):
        assert _contains(cand[n, :count[n]], Q[n])
    ours = all_solutions(model, link, T, limits="ignore")
    assert ours.family.name == "general_6r" and ours.method == "analytic"
    assert (ours.count <= count).all() and ours.count.max() > 8  # more than any subproblem family has
    _pinocchio_exact(model, link, ours, T)


def test_general_6r_unreachable_target_has_no_solutions():
    model = _random_6r(101)
    link = model.leaf_links[0]
    T = np.eye(4)[None].copy()
    T[0, :3, 3] = [5.0, 0.0, 0.0]
    sol = all_solutions(model, link, T, limits="ignore")
    assert sol.count[0] == 0


def test_general_6r_non_finite_targets_have_no_solutions_and_do_not_stop_the_batch():
    model = _random_6r(101)
    link = model.leaf_links[0]
    Q, T = _targets(model, link, 3, seed=2)
    T[1, 0, 3], T[2, 1, 3] = np.nan, 1e300
    sol = all_solutions(model, link, T, limits="ignore")
    assert sol.count[0] >= 1 and sol.count[1] == sol.count[2] == 0
    assert _contains(sol.q[0, :sol.count[0]], Q[0])


@pytest.fixture(scope="module")
def catalogue():
    return default_catalogue()


@pytest.mark.parametrize("model_id, mode, family, kernel, count", [
    ("planar_2r", "position", "planar", "planar_2r", 2),  # elbow up and down
    ("planar_2r", "pose", "planar", "planar_2r", 1),      # the orientation fixes q1 + q2
    ("planar_3r", "pose", "planar", "planar_3r", 2),
    ("scara", "pose", "planar", "planar_3r", 2),          # RRPR: the quill's height, then the planar 3R
    ("rpr_example", "pose", "rpr", "rpr", 1),
])
def test_short_chains_in_closed_form(catalogue, model_id, mode, family, kernel, count):
    model = catalogue.get(model_id)
    link = model.leaf_links[0]
    chain = reduce_chain(model, link)
    fam = detect(chain)
    assert (fam.name, fam.kernel, fam.closed_form) == (family, kernel, True)
    Q, T = _targets(model, link, 40, seed=12)
    sol = all_solutions(model, link, T, limits="ignore", mode=mode)
    assert sol.method == "analytic" and np.all(sol.count == count)
    for n in range(len(Q)):
        assert _contains(sol.q[n, :sol.count[n]], Q[n])
    _pinocchio_exact(model, link, sol, T[:10], position_only=mode == "position")
    # the closed form itself is exact (before any Newton step)
    cand, cnt = ik_general.candidates(kernel, chain, T, mode == "position")
    poe = compile_model(model)
    for n in range(len(T)):
        q = np.zeros((cnt[n], model.dof))
        q[:, chain.columns] = cand[n, :cnt[n]]
        p, r = pose_errors(poe.fk(q, [link])[:, 0], np.repeat(T[n:n + 1], cnt[n], 0))
        assert p.min() < 1e-12
        if mode == "position":
            assert p.max() < 1e-12
        else:
            assert r[p < 1e-12].min() < 1e-12
    # and the search finds nothing more
    search = all_solutions(model, link, T[:4], limits="ignore", mode=mode, method="numeric")
    for n in range(4):
        for q in search.q[n, :search.count[n]]:
            assert _contains(sol.q[n, :sol.count[n]], q)


def test_planar_2r_out_of_reach_and_limits(catalogue):
    model = catalogue.get("planar_2r")
    link = model.leaf_links[0]
    T = np.repeat(np.eye(4)[None], 2, 0)
    T[0, :3, 3] = [1.0, 0.0, 0.0]  # beyond l1 + l2 = 0.9
    T[1, :3, 3] = [0.05, 0.0, 0.0]  # inside l1 − l2 = 0.1
    sol = all_solutions(model, link, T, limits="ignore", mode="position")
    assert sol.method == "analytic" and sol.count.tolist() == [0, 0]
    # at full stretch the two branches meet: one solution, flagged singular
    T = np.eye(4)[None].copy()
    T[0, :3, 3] = [0.0, 0.9, 0.0]
    sol = all_solutions(model, link, T, limits="ignore", mode="position")
    assert sol.count[0] == 1 and sol.singular[0, 0]
    np.testing.assert_allclose(sol.q[0, 0], [np.pi / 2, 0.0], atol=1e-6)


def test_general_6r_twelve_solutions_all_found():
    """A target with 12 real solutions (of at most 16): the elimination lists all 12, the dense search no more."""
    rng = np.random.default_rng(237)
    rows = [{"type": "revolute", "a": float(rng.uniform(0.05, 1.0)), "alpha": float(rng.uniform(-3, 3)),
             "d": float(rng.uniform(-0.5, 0.5)), "theta": 0.0, "limits": [-3.1, 3.1]} for _ in range(6)]
    model = model_from_table(table_from_dict({"name": "twelve", "convention": "standard", "joints": rows}))
    link = model.leaf_links[0]
    q = rng.uniform(-np.pi, np.pi, (40, 6))[15]
    T = compile_model(model).fk(q[None], [link])[:, 0]
    ours = all_solutions(model, link, T, limits="ignore")
    assert ours.count[0] == 12 and _contains(ours.q[0, :12], q)
    search = all_solutions(model, link, T, limits="ignore", method="numeric", search_seeds=4096)
    assert search.count[0] <= 12
    for s in search.q[0, :search.count[0]]:
        assert _contains(ours.q[0, :12], s)
    _pinocchio_exact(model, link, ours, T)


def test_a_7r_arm_with_a_locked_joint_and_no_family_is_a_general_6r():
    rng = np.random.default_rng(77)
    rows = [{"name": f"j{i + 1}", "type": "revolute", "a": float(rng.uniform(0.05, 0.4)),
             "alpha": float(rng.uniform(0.3, 1.3)), "d": float(rng.uniform(0.05, 0.3)), "theta": 0.0,
             "limits": [-3.1, 3.1]} for i in range(7)]
    model = model_from_table(table_from_dict({"name": "random_7r", "convention": "standard", "joints": rows}))
    link = model.leaf_links[0]
    locked = {"j3": 0.7}
    assert detect(reduce_chain(model, link, locked)).name == "general_6r"
    Q = model.sample_configurations(3, np.random.default_rng(5), continuous_range=np.pi)
    Q[:, model.q_index["j3"]] = 0.7
    T = compile_model(model).fk(Q, [link])[:, 0]
    ours = all_solutions(model, link, T, limits="ignore", locked=locked)
    search = all_solutions(model, link, T, limits="ignore", locked=locked, method="numeric", search_seeds=2048)
    cols = [model.q_index[f"j{i}"] for i in (1, 2, 4, 5, 6, 7)]
    for n in range(3):
        mine = ours.q[n, :ours.count[n]]
        assert np.all(mine[:, model.q_index["j3"]] == 0.7)
        assert _contains(mine[:, cols], Q[n, cols])
        for s in search.q[n, :search.count[n]]:
            assert _contains(mine[:, cols], s[cols])
    _pinocchio_exact(model, link, ours, T)


def test_general_6r_batch_equals_single():
    model = _random_6r(101)
    link = model.leaf_links[0]
    _, T = _targets(model, link, 5, seed=8)
    batch = all_solutions(model, link, T, limits="ignore")
    for n in range(len(T)):
        one = all_solutions(model, link, T[n:n + 1], limits="ignore")
        assert one.count[0] == batch.count[n]
        np.testing.assert_array_equal(one.q[0, :one.count[0]], batch.q[n, :batch.count[n]])


def test_analytic_refused_where_a_short_chain_has_no_closed_form(catalogue):
    """A 3R planar arm given a position alone has infinitely many solutions: no closed form lists them."""
    from kinematics.errors import KinematicsError
    model = catalogue.get("planar_3r")
    link = model.leaf_links[0]
    _, T = _targets(model, link, 1, seed=2)
    with pytest.raises(KinematicsError, match="analytic"):
        all_solutions(model, link, T, mode="position", method="analytic")
    assert all_solutions(model, link, T, mode="pose", method="analytic").method == "analytic"


def test_every_ik_geo_general_6r_solution_is_one_of_ours():
    """IK-Geo's general 6R (a 2-D search, the bench extra): each of its answers, polished by the numerical
    solver, is among the elimination's solutions (it finds fewer: its answers are approximate)."""
    ik_geo = pytest.importorskip("ik_geo")
    model = _random_6r(101)
    link = model.leaf_links[0]
    chain = reduce_chain(model, link)
    H = chain.h
    P = np.vstack([chain.r[0], np.diff(chain.r, axis=0), chain.M[:3, 3] - chain.r[-1]])
    geo = ik_geo.Robot.gen_six_dof(H.tolist(), P.tolist())
    _, T = _targets(model, link, 8, seed=3)
    ours = all_solutions(model, link, T, limits="ignore")
    polished = 0
    for n in range(len(T)):
        R = T[n, :3, :3] @ chain.M[:3, :3].T  # their tool frame: the base's orientation at q = 0
        s = np.array([q for q, _ in geo.get_ik(R.T.tolist(), T[n, :3, 3].tolist())]).reshape(-1, 6)
        if not len(s):
            continue
        theirs = inverse_kinematics(model, link, np.repeat(T[n:n + 1], len(s), 0), s, restarts=0,
                                    position_tolerance=1e-10, rotation_tolerance=1e-10)
        for q in theirs.q[theirs.success]:
            polished += 1
            assert _contains(ours.q[n, :ours.count[n]], q), (n, q)
    assert polished > 0
