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


# ---------------------------------------------------------------------------------- the whole self-motion
from kinematics.algorithms import ik_self_motion as sm  # noqa: E402

#: (model, link, targets): the end-joint parameter (one locked chain) and a middle one
WHOLE = [("panda", "panda_link8", 3), ("kuka_lwr4", "tool", 1)]


@pytest.fixture(scope="module")
def whole(catalogue):
    out = {}
    for name, link, n in WHOLE:
        model = catalogue.get(name)
        motion = red.SelfMotion(model, link)
        q, T = _targets(model, link, n, 11)
        pieces, branches = sm.intervals(motion, T)
        out[name] = (motion, q, T, pieces, branches)
    return out


def _branch_near(motion, T, psi, q_ref):
    """The slice's solution at psi nearest q_ref (limits ignored) and its margins."""
    sl = motion.solve(T[None], np.array([psi]), exact=True)
    S = sl.q[0, :sl.count[0]]
    k = int(np.argmin(sm._dist(motion, S, q_ref)))
    return S[k], motion.margins(S[k])


@pytest.mark.parametrize("name", [w[0] for w in WHOLE])
def test_interval_ends_sit_at_a_limit_inside_feasible_outside_not(whole, name):
    motion, q, T, pieces, branches = whole[name]
    checked = 0
    for n in range(len(T)):
        ranges = sm.merged(pieces[n])
        # sorted, disjoint, and the generating configuration's value inside one (it is within the limits)
        assert all(a["to"] < b["from"] for a, b in zip(ranges, ranges[1:]))
        assert any(r["from"] - 1e-9 <= q[n, motion.column] <= r["to"] + 1e-9 for r in ranges)
        for piece in pieces[n]:
            assert piece.lo <= piece.hi
            for side, (psi, step) in enumerate(((piece.lo, -1e-6), (piece.hi, 1e-6))):
                end = piece.ends[side]
                if end["reason"] != "joint_limit":
                    assert end["reason"] in ("parameter_limit", "branch_end")
                    if end["reason"] == "parameter_limit":
                        assert psi in (motion.lower, motion.upper)
                    continue
                at, m = _branch_near(motion, T[n], psi, piece.q[side])
                j = motion.chain.joints.index(end["joint"])
                assert abs(m[j]) < 1e-9 and m.min() > -1e-9, (piece.as_dict(), m)
                _, inside = _branch_near(motion, T[n], psi - step, at)
                _, outside = _branch_near(motion, T[n], psi + step, at)
                assert inside.min() > 0 and outside.min() < 0
                checked += 1
    assert checked > 0


@pytest.mark.parametrize("name, objective", [("panda", o) for o in red.OBJECTIVES] + [("kuka_lwr4", "margin")])
def test_the_best_point_beats_a_dense_sweep(whole, name, objective):
    motion, q, T, pieces, branches = whole[name]
    seed = motion.model.lower_limits * 0.2 + motion.model.upper_limits * 0.8 if objective == "nearest" else None
    goal = sm.Objective(objective, None if seed is None else np.nan_to_num(seed))
    found = sm.best(motion, T, goal, pieces, branches)
    sweep = np.linspace(motion.lower, motion.upper, 2000)
    for n in range(len(T)):
        Q, P, count, within, *_ = red.slices(motion, T[n:n + 1], sweep[None], "respect")
        rows = Q[0, :count[0]]
        assert found[n] is not None and len(rows)
        values = goal.values(motion, rows, motion.margins(rows))
        b = found[n]
        assert b.value >= values.max() - 1e-9, (b.value, values.max())
        # the answer is a solution at its parameter value, within the limits, scoring what it claims
        assert b.q[motion.column] == pytest.approx(b.parameter, abs=1e-12)
        assert motion.margins(b.q).min() >= -1e-9
        assert goal.values(motion, b.q, motion.margins(b.q))[0] == pytest.approx(b.value, abs=1e-12)
        p, r = pose_errors(reference_for(motion.model).poses(b.q)[motion.link][None], T[n:n + 1])
        assert p[0] < EXACT and r[0] < EXACT
