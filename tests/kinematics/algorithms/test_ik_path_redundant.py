"""Cartesian paths of a 7-joint arm along its self-motion (kinematics.algorithms.ik_path_redundant):
a Panda line that jumps with q7 locked goes through along the self-motion; every row exact against
Pinocchio, inside the limits and within max_joint_step of the previous one; each row's objective
not beaten (beyond the documented slack) by a dense sweep of the choices that may follow the previous row; honest stops; bad input
named."""

from __future__ import annotations

import numpy as np
import pytest

import kinematics
from kinematics import compile_model, default_catalogue
from kinematics.algorithms import ik_self_motion as sm
from kinematics.algorithms.ik_path_redundant import SLACK, self_motion_path
from kinematics.algorithms.ik_redundant import SelfMotion
from kinematics.errors import KinematicsError
from tests.kinematics.algorithms.test_ik_redundant import _exact

LINK = "panda_link8"
#: a line on which q2 passes zero (the axes of q1 and q3 line up): singular for the chain with q7 locked
START = np.array([-1.0, -0.1, 0.64, -2.41, -0.48, 0.9, 0.66, 0.0])
MOVE = [0.0, -0.08, -0.025]


@pytest.fixture(scope="module")
def panda():
    return default_catalogue().get("panda")


@pytest.fixture(scope="module")
def motion(panda):
    return SelfMotion(panda, LINK)


@pytest.fixture(scope="module")
def line(panda):
    a = compile_model(panda).fk(START[None], [LINK])[0, 0]
    b = a.copy()
    b[:3, 3] += MOVE
    return np.array([a, b])


@pytest.fixture(scope="module")
def paths(motion, line):
    return {name: self_motion_path(motion, line, name, START) for name in ("nearest", "margin", "manipulability")}


def _continuous_and_exact(panda, ans, max_joint_step=0.3):
    Q = ans.q
    assert np.all(Q >= panda.lower_limits - 1e-12) and np.all(Q <= panda.upper_limits + 1e-12)
    assert np.abs(np.diff(Q, axis=0)).max() <= max_joint_step + 1e-12
    _exact(panda, LINK, Q[:, None], np.ones(len(Q), int), ans.targets[:len(Q)])


def test_a_panda_line_jumps_with_q7_locked_and_not_along_the_self_motion(panda, line, paths):
    locked = kinematics.ik_path(panda, line, link=LINK, seed=START, locked={"panda_joint7": START[6]})
    assert locked.stopped == {"index": 5, "reason": "joint_jump"} and not locked.complete
    ans = paths["nearest"]
    assert ans.complete and ans.stopped is None and len(ans.q) == len(ans.targets) == 10
    np.testing.assert_allclose(ans.q[0], START, atol=1e-9)  # the first row is the seed (it reaches the start)
    _continuous_and_exact(panda, ans)
    assert ans.max_joint_step < 0.03  # no joint spins where the locked chain's q1 and q3 would
    assert np.ptp(ans.q[:, 6]) > 5e-3  # q7 moves: the self-motion is used
    # the library's keyword reaches the same continuation
    same = kinematics.ik_path(panda, line, link=LINK, seed=START, redundancy={"select": "nearest"})
    np.testing.assert_array_equal(same.q, ans.q)


@pytest.mark.parametrize("objective", ["margin", "manipulability"])
def test_every_objective_is_continuous_and_exact(panda, paths, objective):
    ans = paths[objective]
    assert ans.complete
    np.testing.assert_allclose(ans.q[0], START, atol=1e-9)
    _continuous_and_exact(panda, ans)


def _choices(motion, T, prev, max_joint_step, n=801):
    """Every slice solution at n values within max_joint_step of prev's parameter, as the 2 pi copy
    nearest prev, that lies inside the limits and within max_joint_step of prev in every joint."""
    cols, rev = motion.chain.columns, motion.chain.revolute.copy()
    rev[motion.k] = False
    psi = np.linspace(prev[motion.column] - max_joint_step, prev[motion.column] + max_joint_step, n)
    psi = psi[(psi >= motion.lower) & (psi <= motion.upper)]
    sl = motion.solve(np.repeat(T[None], len(psi), axis=0), psi, exact=True)
    out = []
    for r in range(len(psi)):
        for q in sl.q[r, :sl.count[r]]:
            x = q[cols]
            x = np.where(rev, prev[cols] + np.mod(x - prev[cols] + np.pi, 2 * np.pi) - np.pi, x)
            row = prev.copy()
            row[cols] = x
            inside = np.all((row >= motion.model.lower_limits) & (row <= motion.model.upper_limits))
            if inside and np.abs(row - prev).max() <= max_joint_step:
                out.append(row)
    return np.array(out)


@pytest.mark.parametrize("objective", ["nearest", "margin", "manipulability"])
def test_no_choice_of_a_dense_sweep_beats_a_row(motion, paths, objective):
    ans = paths[objective]
    for i in (1, 5, 9):
        prev, row = ans.q[i - 1], ans.q[i]
        goal = sm.Objective("nearest", prev) if objective == "nearest" else sm.Objective(objective)
        C = _choices(motion, ans.targets[i], prev, 0.3)
        assert len(C)
        swept = goal.values(motion, C, motion.margins(C)).max()
        ours = goal.values(motion, row, motion.margins(row))[0]
        # nearest: the least step; the others: within SLACK of the best (then the least step among those)
        slack = 1e-7 if objective == "nearest" else SLACK * abs(swept) + 1e-7
        assert ours >= swept - slack, (i, ours, swept)


def test_stops_where_no_continuous_choice_exists(panda, motion, line):
    # a step far below what one centimetre needs: no row can follow the first
    ans = self_motion_path(motion, line, "nearest", START, max_joint_step=1e-4)
    assert ans.stopped == {"index": 1, "reason": "joint_jump"} and len(ans.q) == 1
    # out of reach: the rows before the stop are exact and continuous
    far = line.copy()
    far[1, :3, 3] = [1.2, 0.0, 0.4]
    ans = self_motion_path(motion, far, "nearest", START, step_position=0.02)
    assert ans.stopped["reason"] == "unreachable" and 0 < len(ans.q) == ans.stopped["index"]
    assert np.linalg.norm(ans.targets[len(ans.q), :3, 3]) > np.linalg.norm(ans.targets[len(ans.q) - 1, :3, 3])
    _continuous_and_exact(panda, ans)


def test_without_a_seed_the_path_starts_at_the_best_point(motion, line):
    ans = self_motion_path(motion, line[::-1], "margin", None)
    top = sm.best(motion, ans.targets[:1], sm.Objective("margin"))[0]
    np.testing.assert_allclose(ans.q[0, :7], top.q[:7], atol=1e-9)


def test_bad_redundancy_on_a_path_is_named(panda, line):
    ur5 = default_catalogue().get("ur5")
    T = compile_model(ur5).fk(np.array([[0.3, -1.0, 1.2, -0.5, 0.8, 0.2]]), ["tool0"])[0, 0]
    with pytest.raises(KinematicsError, match="not redundant"):
        kinematics.ik_path(ur5, np.array([T, T]), link="tool0", redundancy={"select": "nearest"})
    with pytest.raises(KinematicsError, match="redundancy.select"):
        kinematics.ik_path(panda, line, link=LINK, redundancy={"select": "fastest"})
    with pytest.raises(KinematicsError, match="not values or intervals"):
        kinematics.ik_path(panda, line, link=LINK, redundancy={"select": "nearest", "values": [0.1]})
    with pytest.raises(KinematicsError, match="panda_joint9"):
        kinematics.ik_path(panda, line, link=LINK, redundancy={"select": "nearest", "parameter": "panda_joint9"})


def test_with_a_collision_filter_the_self_motion_keeps_clear(panda, motion, line, paths):
    # "in collision" where q1 < -1.03: the nearest path goes there (q1 reaches -1.076), this one may not
    assert paths["nearest"].q[:, 0].min() < -1.05
    free = lambda Q: np.asarray(Q)[:, 0] >= -1.03  # noqa: E731
    ans = self_motion_path(motion, line, "nearest", START, collision_free=free)
    assert ans.complete and free(ans.q).all() and ans.q[:, 0].min() == pytest.approx(-1.03, abs=1e-6)
    np.testing.assert_allclose(ans.q[0], START, atol=1e-9)
    _continuous_and_exact(panda, ans)
    # a seed in collision: the first row is the nearest free point; where the free choices end: collision
    free = lambda Q: np.asarray(Q)[:, 0] >= -0.95  # noqa: E731
    ans = self_motion_path(motion, line, "nearest", START, collision_free=free)
    assert ans.q[0, 0] == pytest.approx(-0.95, abs=1e-9) and free(ans.q).all()
    assert ans.stopped == {"index": len(ans.q), "reason": "collision"} and len(ans.q) > 1
    _continuous_and_exact(panda, ans)
