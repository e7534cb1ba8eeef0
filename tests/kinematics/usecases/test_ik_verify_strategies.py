"""``verify=True`` checks one IK answer with Pinocchio whatever the strategy chose it: the numerical
solver's, the nearest of the full set (``method="analytic"``, ``locked`` joints) or a caller's."""

import numpy as np
import pytest

import kinematics
from kinematics.algorithms.ik import IKSolution
from kinematics.usecases.ik_select import NearestOfSet

PANDA_LOCKED = {"panda_joint3": 0.2}


def _targets(model, link, n=3, seed=7, locked=None):
    lo, hi = np.maximum(model.lower_limits, -2.0), np.minimum(model.upper_limits, 2.0)
    Q = np.random.default_rng(seed).uniform(lo, hi, (n, model.dof))
    for name, value in (locked or {}).items():
        Q[:, model.q_index[name]] = value
    return kinematics.fk(model, Q, links=[link]).poses[:, 0]


def _own_errors(model, link, q, T):
    """Position and rotation errors of the answers' FK (ours) against the targets."""
    P = kinematics.fk(model, q, links=[link]).poses[:, 0]
    position = np.linalg.norm(P[:, :3, 3] - T[:, :3, 3], axis=1)
    R = np.einsum("nji,njk->nik", P[:, :3, :3], T[:, :3, :3])
    rotation = np.arccos(np.clip((np.trace(R, axis1=1, axis2=2) - 1) / 2, -1.0, 1.0))
    return position, rotation


@pytest.mark.parametrize("name, link, keywords", [
    ("ur5", "tool0", {"method": "analytic"}),
    ("panda", "panda_hand", {"locked": PANDA_LOCKED}),
    ("ur5", "tool0", {}),  # the numerical solver's answer, verified before too
])
def test_every_strategy_answer_is_verified(catalogue, name, link, keywords):
    model = catalogue.get(name)
    T = _targets(model, link, locked=keywords.get("locked"))
    answer = kinematics.ik(model, T, link=link, verify=True, **keywords)
    assert answer.solution.success.all()
    v = answer.verification
    assert v is not None, f"{keywords}: no verification"
    assert v["reference"].startswith("pinocchio")
    assert v["position_error"].shape == v["rotation_error"].shape == (len(T),)
    assert v["position_error"].max() < 1e-9 and v["rotation_error"].max() < 1e-9
    assert kinematics.ik(model, T, link=link, **keywords).verification is None  # only when asked


def test_a_caller_strategy_is_verified_on_its_answer_not_its_claim(ur5):
    """A strategy over the full set that answers a wrong q (and claims no error) is caught."""

    class Wrong(NearestOfSet):
        def select(self, problem):
            n = len(problem.T)
            q = np.zeros((n, problem.model.dof))
            return IKSolution(q, np.ones(n, bool), np.zeros(n), np.zeros(n), np.zeros(n, np.int64)), None

    T = _targets(ur5, "tool0")
    answer = kinematics.ik(ur5, T, link="tool0", method="analytic", select=Wrong(), verify=True)
    v = answer.verification
    assert v is not None
    position, rotation = _own_errors(ur5, "tool0", answer.solution.q, T)
    assert position.min() > 1e-3
    assert np.allclose(v["position_error"], position, atol=1e-9)
    assert np.allclose(v["rotation_error"], rotation, atol=1e-7)
