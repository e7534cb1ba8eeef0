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
    got, got_owner = ik_all._all_copies(model, chain, rows, owner)
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
