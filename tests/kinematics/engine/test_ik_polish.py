"""The compiled per-target pass of every IK solution (kinematics/engine/ik_polish.py)."""

import numpy as np
import pytest

from kinematics import compile_model, default_catalogue
from kinematics.algorithms import ik_all
from kinematics.algorithms.ik_families import reduce_chain
from kinematics.engine import ik_polish

CASES = [("ur5", "tool0", None), ("puma560_standard", "tool", None), ("panda", "panda_link8", {"panda_joint7": 0.5})]


@pytest.mark.parametrize("rid, link, locked", CASES)
def test_chain_fk_and_jacobian_are_the_models(rid, link, locked):
    model = default_catalogue().get(rid)
    poe = compile_model(model)
    chain = reduce_chain(model, link, locked)
    Q = model.sample_configurations(20, np.random.default_rng(1))
    for name, v in (locked or {}).items():
        Q[:, model.q_index[name]] = v
    T = poe.fk(Q, [link])[:, 0]
    J = poe.jacobian(Q, link, "local_world_aligned")[:, :, chain.columns]
    n = chain.n
    F, W, O, Jc = np.empty((4, 4)), np.empty((n, 3)), np.empty((n, 3)), np.empty((6, n))
    sn, cs = np.empty(n), np.empty(n)
    for i in range(len(Q)):
        x = np.ascontiguousarray(Q[i, chain.columns])
        ik_polish.chain_fk(chain.h, chain.r, chain.revolute, chain.M, x, F, W, O, sn, cs)
        ik_polish.chain_jacobian(chain.revolute, F, W, O, Jc)
        assert np.abs(F - T[i]).max() < 1e-12
        assert np.abs(Jc - J[i]).max() < 1e-12


@pytest.mark.parametrize("rid, link, locked", CASES)
def test_compiled_copies_equal_the_reference(rid, link, locked):
    model = default_catalogue().get(rid)
    chain = reduce_chain(model, link, locked)
    rows = np.random.default_rng(0).uniform(-np.pi, np.pi, size=(60, model.dof))
    owner = np.arange(60) // 3
    ref = [(o, c) for s, o in zip(rows, owner) for c in ik_all._copies(model, chain, s)]
    got, got_owner = ik_all.all_copies(model, chain, rows, owner)
    assert len(ref) == len(got) > 0
    assert np.array_equal(np.array([c for _, c in ref]), got)
    assert np.array_equal(np.array([o for o, _ in ref]), got_owner)


def test_singular_ratio_is_the_svd():
    rng = np.random.default_rng(4)
    A = np.empty((6, 6))
    for _ in range(20):
        J = rng.normal(size=(6, 6)) @ np.diag([1, 1, 1, 1, 1, 10.0 ** rng.uniform(-9, 0)])
        s = np.linalg.svd(J, compute_uv=False)
        assert ik_polish.singular_ratio2(np.ascontiguousarray(J), A) == pytest.approx((s[-1] / s[0]) ** 2, rel=1e-6, abs=1e-20)


def test_a_batch_equals_its_targets_alone_and_threads_do_not_change_bits():
    from kinematics.engine.parallel import threads

    model = default_catalogue().get("ur5")
    Q = model.sample_configurations(300, np.random.default_rng(5))
    T = compile_model(model).fk(Q, ["tool0"])[:, 0]
    with threads(1):
        one = ik_all.all_solutions(model, "tool0", T, limits="ignore")
    with threads(2):
        two = ik_all.all_solutions(model, "tool0", T, limits="ignore")
    assert np.array_equal(one.count, two.count) and np.array_equal(one.q, two.q, equal_nan=True)
    for i in (0, 17, 299):
        alone = ik_all.all_solutions(model, "tool0", T[i:i + 1], limits="ignore")
        k = alone.count[0]
        assert k == one.count[i] and np.array_equal(alone.q[0, :k], one.q[i, :k])


def _lane_inputs(rid, link, locked, count, rng):
    """Candidates near and far from targets of a chain: ``cand`` (N, 8, n) per target, half of them the
    generating configuration plus noise from 0 to 1 rad, and a wrist-singular one where the chain has q5."""
    model = default_catalogue().get(rid)
    chain = reduce_chain(model, link, locked)
    Q = model.sample_configurations(count, rng)
    for name, v in (locked or {}).items():
        Q[:, model.q_index[name]] = v
    T = np.ascontiguousarray(compile_model(model).fk(Q, [link])[:, 0])
    x = Q[:, chain.columns]
    noise = 10.0 ** rng.uniform(-16, 0, size=(count, 8, 1)) * rng.normal(size=(count, 8, chain.n))
    noise[:, ::2] = 0.0
    cand = np.ascontiguousarray(x[:, None, :] + noise)
    if chain.n == 6:
        cand[:, 2, 4] = 0.0  # the wrist (or elbow) lined up: a singular Jacobian where q5 is the wrist
    return chain, T, cand


@pytest.mark.parametrize("rid, link, locked", CASES)
def test_the_lane_stage_measures_as_the_scalar_path(rid, link, locked):
    rng = np.random.default_rng(11)
    N = 12
    chain, T, cand = _lane_inputs(rid, link, locked, N, rng)
    n = chain.n
    ccount = np.full(N, 8, dtype=np.int64)
    table, D = ik_polish.lane_table(chain.h, chain.r, chain.M)
    L = N * 8 + 8
    X, F, S = np.empty((n, L)), np.empty((n, 12, L)), np.empty((2, n, L))
    TT, E, JL, Gm = np.empty((12, L)), np.empty((12, L)), np.empty((6 * n, L)), np.empty((21, L))
    lp, lq, lb = np.empty(L), np.empty(L), np.empty(L)
    m = ik_polish.lane_stage(cand, ccount, False, T, chain.revolute, table, D, 0, N, (X, F, S, TT, E, JL, Gm, lp, lq, lb))
    assert m == N * 8
    work = ik_polish.scratch(n)
    Fs, W, O, J, A = *work[:4], work[7]
    small = decided = 0
    for lane in range(m):
        t, c = divmod(lane, 8)
        x = cand[t, c].copy()
        ik_polish.wrap(x, chain.revolute)
        assert np.array_equal(X[:, lane], x)
        p, q = ik_polish.chain_error((chain.h, chain.r, chain.revolute, chain.M), x, T[t], work)
        assert lp[lane] == pytest.approx(p, rel=1e-9, abs=1e-15)
        if np.isnan(lq[lane]):  # the lane leaves large rotation errors to the scalar path
            assert q > 0.9 * ik_polish.LANE_SMALL_ANGLE
        else:
            small += 1
            assert lq[lane] == pytest.approx(q, rel=1e-9, abs=1e-15)
        ik_polish.chain_jacobian(chain.revolute, Fs, W, O, J)
        if n != 6:
            continue
        s = np.linalg.svd(J, compute_uv=False)
        if np.isfinite(lb[lane]):
            exact = ik_polish.det_bound(J, A)
            if exact > 1e-6:  # (JᵀJ squares the condition: below, the bound is only small, as it should be)
                decided += 1
                assert lb[lane] == pytest.approx(exact, rel=1e-6)
            if lb[lane] > ik_all.SINGULAR:  # what polish trusts the lane bound for: a regular Jacobian
                assert s[-1] / s[0] > ik_all.SINGULAR
        else:  # the factor broke down: only on a (nearly) singular Jacobian
            assert s[-1] / s[0] < 1e-6
    assert small >= m // 2 and (n != 6 or decided >= m // 2)
