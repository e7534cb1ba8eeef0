"""``solutions="one"`` on a 7-joint chain with ``redundancy.select``: the one best solution over the
whole self-motion (:class:`kinematics.usecases.ik_redundant.BestOverSelfMotion`), the same point as
the every-solution answer's best, exact by Pinocchio; and over REST."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import fk, ik
from kinematics.errors import KinematicsError
from kinematics.usecases.ik_redundant import BestOverSelfMotion

Q = np.array([[0.3, -0.5, 0.2, -2.0, 0.4, 1.8, 0.7, 0.0], [-0.4, 0.3, -0.6, -1.5, 0.2, 2.2, -0.9, 0.0]])


@pytest.fixture(scope="module")
def targets(catalogue):
    panda = catalogue.get("panda")
    return panda, fk(panda, Q, links=["panda_link8"]).poses[:, 0]


@pytest.mark.parametrize("objective", ["margin", "nearest"])
def test_one_answer_is_the_best_point_of_the_whole_self_motion(targets, objective):
    panda, T = targets
    every = ik(panda, T, link="panda_link8", solutions="all", redundancy={"select": objective}, seed=Q[0])
    one = ik(panda, T, link="panda_link8", redundancy={"select": objective}, seed=Q[0], verify=True)
    assert one.solution.success.all()
    np.testing.assert_array_equal(one.solution.q, every.q[:, 0])
    assert np.max(one.verification["position_error"]) < 1e-9
    assert np.max(one.verification["rotation_error"]) < 1e-9
    same = ik(panda, T, link="panda_link8", select=BestOverSelfMotion(objective), seed=Q[0])
    np.testing.assert_array_equal(same.solution.q, one.solution.q)


def test_one_answer_with_values_or_intervals_is_refused(targets):
    panda, T = targets
    with pytest.raises(KinematicsError, match="with solutions 'one' give select"):
        ik(panda, T[0], link="panda_link8", redundancy={"values": [0.3]})
    with pytest.raises(KinematicsError, match="with solutions 'one' give select"):
        ik(panda, T[0], link="panda_link8", redundancy={"select": "margin", "intervals": True})


def test_the_service_answers_the_best_point_as_one_solution(targets, api_client):
    panda, T = targets
    body = {"link": "panda_link8", "target": T[0].tolist(), "redundancy": {"select": "margin"}}
    r = api_client.post("/models/panda/ik", json=body)
    assert r.status_code == 200, r.text
    lib = ik(panda, T[0], link="panda_link8", redundancy={"select": "margin"})
    np.testing.assert_allclose(r.json()["q"], lib.solution.q[0], rtol=0, atol=1e-12)
    r = api_client.post("/models/panda/ik", json={**body, "redundancy": {"values": [0.2]}})
    assert r.status_code == 422 and "give select" in r.text
