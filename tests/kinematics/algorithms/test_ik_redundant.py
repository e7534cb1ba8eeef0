"""Every solution of a 7-joint arm (kinematics.algorithms.ik_redundant): the parameter each arm runs
along, slices exact against Pinocchio's FK and complete (the generating configuration always among
them), intervals whose ends sit at a joint limit, and a best point no dense sweep improves on."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import compile_model, default_catalogue
from kinematics.algorithms import ik_redundant as red
from kinematics.algorithms.ik import pose_errors
from kinematics.errors import KinematicsError, LockedJointError
from kinematics.verify.pinocchio import reference_for

EXACT = 1e-9

#: (model, link, the default parameter, another parameter inside the chain)
ARMS = [
    ("panda", "panda_link8", "panda_joint7", "panda_joint6"),
    ("kuka_lwr4", "tool", "joint_3", "joint_1"),
    ("xarm7", "link_eef", "joint7", "joint6"),
]


@pytest.fixture(scope="module")
def catalogue():
    return default_catalogue()


def _targets(model, link, n, seed):
    rng = np.random.default_rng(seed)
    lo, hi = model.lower_limits, model.upper_limits
    q = lo + (hi - lo) * rng.random((n, model.dof))
    return q, compile_model(model).fk(q, [link])[:, 0]


def _exact(model, link, q, count, T, regular=None):
    """Every listed solution (those marked ``regular``) within 1e-9 of its target by Pinocchio's FK."""
    ref = reference_for(model)
    for n in range(len(T)):
        for k in range(int(count[n])):
            if regular is not None and not regular[n, k]:
                continue
            p, r = pose_errors(ref.poses(q[n, k])[link][None], T[n:n + 1])
            assert p[0] < EXACT and r[0] < EXACT, (n, k, p, r)


@pytest.mark.parametrize("name, link, default, other", ARMS)
def test_the_default_parameter_moves_along_the_self_motion_with_a_closed_form(catalogue, name, link, default, other):
    model = catalogue.get(name)
    choice = red.parameters(model, link)
    assert choice.default == default
    assert default in choice.joints and other in choice.joints
    # the elbow of an arm with a spherical shoulder and wrist stays put along the self-motion: no parameter
    if name == "kuka_lwr4":
        assert "joint_4" not in choice.joints and choice.motion["joint_4"] < red.STILL
    d = choice.as_dict()
    assert d["redundant"] and d["default_parameter"] == {"joint": default}


@pytest.mark.parametrize("name, link, default, other", ARMS)
@pytest.mark.parametrize("which", ["default", "other"])
def test_slices_list_the_generating_configuration_and_are_exact(catalogue, name, link, default, other, which):
    model = catalogue.get(name)
    motion = red.SelfMotion(model, link, default if which == "default" else other)
    q, T = _targets(model, link, 12, 5)
    cols = motion.chain.columns
    # at the generating value, plus two other values for every target (one list for all)
    V = np.concatenate([q[:, motion.column][:, None], np.broadcast_to([-0.7, 1.1], (12, 2))], axis=1)
    Q, P, count, within, singular, pe, re, complete, family, method = red.slices(motion, T, V, "respect")
    assert method == "analytic" and complete.all()
    for n in range(12):
        listed = Q[n, :count[n]]
        assert np.all(np.isin(P[n, :count[n]], V[n]))
        assert np.all(listed[:, motion.column] == P[n, :count[n]])
        at = P[n, :count[n]] == V[n, 0]
        assert np.abs(listed[at][:, cols] - q[n, cols]).max(axis=1).min() < 1e-8, n
        assert within[n, :count[n]].all()
    # exact to 1e-9; a double root (two branches meeting: flagged singular) converges only linearly under
    # Newton and is held to the request's tolerance
    regular = ~singular & (np.arange(Q.shape[1])[None] < count[:, None])
    assert pe[regular].max() < EXACT and re[regular].max() < EXACT
    assert np.nanmax(pe) < 1e-6 and np.nanmax(re) < 1e-6
    _exact(model, link, Q, count, T, regular)


def test_an_end_joint_and_a_locked_chain_agree(catalogue):
    """The Panda's q7 slices (the value moves the target) are the locked chain's own solutions."""
    from kinematics.algorithms.ik_all import all_solutions

    model = catalogue.get("panda")
    motion = red.SelfMotion(model, "panda_link8")
    assert motion.end
    _, T = _targets(model, "panda_link8", 6, 9)
    for v in (-2.0, 0.3, 2.5):
        Q, P, count, *_ = red.slices(motion, T, np.full((6, 1), v), "ignore")
        ref = all_solutions(model, "panda_link8", T, locked={"panda_joint7": v}, limits="ignore")
        assert np.array_equal(count, ref.count)
        for n in range(6):
            for k in range(count[n]):
                assert np.abs(ref.q[n, :ref.count[n], :7] - Q[n, k, :7]).max(axis=1).min() < 1e-9


def test_values_outside_the_parameter_limits(catalogue):
    model = catalogue.get("panda")
    motion = red.SelfMotion(model, "panda_link8")
    _, T = _targets(model, "panda_link8", 4, 1)
    V = np.full((4, 1), 3.0)  # beyond q7's 2.8973
    assert red.slices(motion, T, V, "respect")[2].sum() == 0
    Q, P, count, within, *_ = red.slices(motion, T, V, "ignore")
    assert count.sum() > 0 and not within[:, :count.max()][np.arange(count.max())[None] < count[:, None]].any()
    _exact(model, "panda_link8", Q, count, T)


def test_bad_parameters_are_named(catalogue):
    model = catalogue.get("panda")
    with pytest.raises(LockedJointError, match="panda_joint9"):
        red.SelfMotion(model, "panda_link8", "panda_joint9")
    with pytest.raises(LockedJointError, match="not a free joint"):
        red.SelfMotion(model, "panda_link8", "panda_finger_joint1")
    with pytest.raises(KinematicsError, match="not redundant"):
        red.SelfMotion(catalogue.get("ur5"), "tool0")
    with pytest.raises(KinematicsError, match="lock 1 of them"):
        red.SelfMotion(catalogue.get("panda"), "panda_leftfinger")
    with pytest.raises(KinematicsError, match="finite"):
        red.Redundancy.of({"values": [0.1, float("nan")]})
    with pytest.raises(KinematicsError, match="select"):
        red.Redundancy.of({"select": "best"})
