"""The compiled closed forms (kinematics.engine.ik_fast), checked against their definition: on the
ideal chain of each family, a target made from random joint values gives candidates that contain
those values, every candidate flagged exact reproduces the target by the product of exponentials,
and a target out of reach is never flagged exact."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import default_catalogue
from kinematics.algorithms.ik_families import detect, reduce_chain
from kinematics.engine import ik_fast
from kinematics.engine.subproblems import EXACT, rot

CASES = [("ur5", "tool0", None), ("puma560_standard", "tool", None), ("stanford_arm", "tool", None),
         ("panda", "panda_link8", {"panda_joint7": 0.3}), ("kuka_lwr4", "tool", {"joint_3": 0.2})]
N = 200


def product(h, r, revolute, q):
    """``E1(q1) ... E6(q6)`` (4, 4) of the chain's screws: about the axis ``h_j`` through ``r_j``
    (revolute) or along ``h_j`` (prismatic)."""
    G = np.eye(4)
    for j in range(len(q)):
        E = np.eye(4)
        if revolute[j]:
            E[:3, :3] = rot(h[j], q[j])
            E[:3, 3] = r[j] - E[:3, :3] @ r[j]
        else:
            E[:3, 3] = q[j] * h[j]
        G = G @ E
    return G


def run(fam, G, width):
    ideal = fam.ideal
    h, r, c = np.ascontiguousarray(ideal.h), np.ascontiguousarray(ideal.r), np.ascontiguousarray(fam.centre)
    C = ik_fast.FAMILY_CANDIDATES
    Q = np.zeros((len(G), C, 6)); count = np.zeros(len(G), np.int64); flag = np.zeros((len(G), C), np.int64)
    if fam.kernel == "spherical_wrist":
        ik_fast.spherical_wrist(G, h, r, not bool(ideal.revolute[2]), c, fam.position, width, Q, count, flag)
    else:
        assert fam.kernel == "three_parallel"
        ik_fast.three_parallel(G, h, r, c, width, Q, count, flag)
    return Q, count, flag


@pytest.mark.parametrize("model_id, link, locked", CASES)
@pytest.mark.parametrize("width", [0.0, 0.05])
def test_candidates_contain_the_generating_values_and_exact_ones_are_solutions(model_id, link, locked, width):
    model = default_catalogue().get(model_id)
    fam = detect(reduce_chain(model, link, locked))
    ideal = fam.ideal
    rng = np.random.default_rng(4)
    q = rng.uniform(-np.pi, np.pi, (N, 6))
    q[:, ~ideal.revolute] = rng.uniform(0.1, 0.5, (N, int((~ideal.revolute).sum())))
    G = np.ascontiguousarray([product(ideal.h, ideal.r, ideal.revolute, x) for x in q])
    Q, count, flag = run(fam, G, width)
    exact = 0
    for i in range(N):
        cand = Q[i, :count[i]]
        d = cand - q[i]
        d[:, ideal.revolute] = np.mod(d[:, ideal.revolute] + np.pi, 2 * np.pi) - np.pi
        assert np.abs(d).max(axis=1).min() < 1e-7, (model_id, i)
        for x, f in zip(cand, flag[i, :count[i]]):
            if f == EXACT:
                exact += 1
                np.testing.assert_allclose(product(ideal.h, ideal.r, ideal.revolute, x), G[i], atol=1e-9)
    assert exact >= N


@pytest.mark.parametrize("model_id, link, locked", [c for c in CASES if c[0] != "stanford_arm"])  # (a slide reaches far)
def test_a_target_out_of_reach_is_never_flagged_exact(model_id, link, locked):
    model = default_catalogue().get(model_id)
    fam = detect(reduce_chain(model, link, locked))
    rng = np.random.default_rng(5)
    G = np.ascontiguousarray(np.tile(np.eye(4), (50, 1, 1)))
    G[:, :3, 3] = rng.normal(size=(50, 3))
    G[:, :3, 3] *= 100.0 / np.linalg.norm(G[:, :3, 3], axis=1, keepdims=True)  # 100 m away
    _, count, flag = run(fam, G, 0.0)
    assert count.min() >= 1
    for i in range(50):
        assert np.all(flag[i, :count[i]] != EXACT)  # least squares (or degenerate)
