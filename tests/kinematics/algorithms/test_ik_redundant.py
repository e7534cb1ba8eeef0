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


# ---------------------------------------------------------------------------------- a real arm near its family
#: configurations of the iiwa14 (the Robotics Toolbox data package's URDF) with joint_a7 = -1.371: near a
#: stretched elbow (joint_a4 about 0.03-0.12); at each, the locked chain (joint_a7) lists none or two of
#: four solutions within the limits and says the set is complete before the near family is proven
IIWA_NEAR_ELBOW = [
    [-0.0324, -0.8721, -2.0376, 0.0328, -0.8982, 0.3224, -1.371],
    [1.7205, -0.2834, 1.4243, 0.0376, -0.3874, 1.6683, -1.371],
    [-1.1678, -0.1948, -2.1715, 0.1088, -1.7596, -0.9955, -1.371],
    [2.8704, -2.0827, -0.796, -0.093, 0.8308, -1.8993, -1.371],
]


@pytest.fixture(scope="module")
def iiwa14():
    """The KUKA LBR iiwa 14 R820 URDF shipped by rtb-data: joint_a2 at x = -0.00043624, so its shoulder
    axes miss each other by 0.44 mm (a near family, not an exact one)."""
    rtbdata = pytest.importorskip("rtbdata")
    from pathlib import Path

    from kinematics.io.urdf import load_urdf

    path = Path(rtbdata.__file__).parent / "xacro/kuka_description/kuka_lbr_iiwa/urdf/lbr_iiwa_14_r820.urdf"
    if not path.exists():
        pytest.skip("rtb-data ships no iiwa14 URDF here")
    return load_urdf(path)


def _same(a, b, cols):
    return np.abs(np.angle(np.exp(1j * (a[:, cols] - b[cols])))).max(axis=1).min(initial=np.inf) < 1e-6


def _complete_against_multistart(model, link, Q, count, complete, q_gen, T, free):
    """Where the answer says complete: the generating configuration is listed, every configuration an
    independent multistart on Pinocchio finds within the limits is listed, and all are exact."""
    from kinematics.verify.pinocchio import multistart_solutions

    for n in range(len(T)):
        listed = Q[n, :count[n]]
        if not complete[n]:
            continue
        assert _same(listed, q_gen[n], free), (n, count[n])
        reference = multistart_solutions(model, link, T[n], free, q_gen[n], seeds=160, seed=n)
        inside = np.all((reference >= model.lower_limits - 1e-9) & (reference <= model.upper_limits + 1e-9), axis=1)
        for q in reference[inside]:
            assert _same(listed, q, free), (n, q, count[n])
    _exact(model, link, Q, count, T)


def test_the_real_iiwa14_near_a_stretched_elbow_with_joint_a7_locked_lists_every_solution(iiwa14):
    from kinematics.algorithms.ik_all import all_solutions

    q = np.array(IIWA_NEAR_ELBOW)
    T = compile_model(iiwa14).fk(q, ["tool0"])[:, 0]
    sol = all_solutions(iiwa14, "tool0", T, locked={"joint_a7": -1.371})
    assert sol.family.near and sol.family.name == "spherical_shoulder_intersecting_12"
    assert sol.complete.all()  # proven here (the elimination of the real chain), not merely claimed
    _complete_against_multistart(iiwa14, "tool0", sol.q, sol.count, sol.complete, q, T, np.arange(6))


def test_the_real_iiwa14_slice_at_joint_a7_minus_1_371_is_not_empty(iiwa14):
    motion = red.SelfMotion(iiwa14, "tool0", "joint_a7")
    q = np.array(IIWA_NEAR_ELBOW[:2])
    T = compile_model(iiwa14).fk(q, ["tool0"])[:, 0]
    Q, P, count, within, singular, pe, re, complete, family, method = red.slices(motion, T, np.full((2, 1), -1.371))
    assert np.all(count == 4) and complete.all()
    _complete_against_multistart(iiwa14, "tool0", Q, count, complete, q, T, np.arange(6))


def test_the_real_iiwa14_with_joint_a3_locked_is_its_near_closed_form_and_complete(iiwa14):
    """joint_a3 locked: a spherical wrist on a shoulder whose axes miss by 0.44 mm is the near
    intersecting family (projected, solved in closed form, polished, proven), not the elimination of a
    general arm; random targets, and targets near a stretched elbow."""
    from kinematics.algorithms.ik_all import all_solutions
    from kinematics.algorithms.ik_families import detect, reduce_chain

    fam = detect(reduce_chain(iiwa14, "tool0", {"joint_a3": 0.4}))
    assert (fam.name, fam.near, fam.kernel) == ("spherical_wrist_intersecting_12", True, "spherical_wrist")
    rng = np.random.default_rng(3)
    lo, hi = iiwa14.lower_limits, iiwa14.upper_limits
    q = lo + (hi - lo) * rng.random((40, 7))
    q[:, 2] = 0.4
    q[20:, 3] = rng.uniform(0.03, 0.12, 20) * rng.choice([-1, 1], 20)
    T = compile_model(iiwa14).fk(q, ["tool0"])[:, 0]
    sol = all_solutions(iiwa14, "tool0", T, locked={"joint_a3": 0.4})
    free = np.array([0, 1, 3, 4, 5, 6])
    for n in range(40):  # the generating configuration is listed wherever the answer says complete
        assert not sol.complete[n] or _same(sol.q[n, :sol.count[n]], q[n], free), n
    assert sol.complete.mean() > 0.9
    pick = np.r_[0:3, 20:23]
    _complete_against_multistart(iiwa14, "tool0", sol.q[pick], sol.count[pick], sol.complete[pick], q[pick], T[pick],
                                 free)
