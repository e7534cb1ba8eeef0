"""The best point of a 7-joint arm's self-motion free of self-collision
(kinematics.algorithms.ik_self_motion_free), and avoid_collisions with redundancy through
kinematics.ik: a filter that cuts the self-motion moves the best point to the last free one (no
free point of a dense sweep is better); with the model's own matrix the answer is free, and the
slices leave the colliding solutions out, counted."""

from __future__ import annotations

import numpy as np
import pytest

import kinematics
from kinematics import default_catalogue
from kinematics.algorithms import ik_redundant as red
from kinematics.algorithms import ik_self_motion as sm
from kinematics.algorithms.ik_self_motion_free import best_free
from kinematics.errors import KinematicsError
from kinematics.usecases.collision import collision_filter
from tests.kinematics.algorithms.test_ik_redundant import _exact

LINK = "panda_link8"
Q = np.array([0.3, -0.5, 0.2, -2.0, 0.4, 1.8, 0.7, 0.03])  # the fingers open: closed, they touch


@pytest.fixture(scope="module")
def panda():
    return default_catalogue().get("panda")


@pytest.fixture(scope="module")
def whole(panda):
    motion = red.SelfMotion(panda, LINK)
    T = kinematics.fk(panda, Q, links=[LINK]).poses[0, 0][None]
    pieces, branches = sm.intervals(motion, T)
    return motion, T, pieces, branches


@pytest.mark.parametrize("objective", red.OBJECTIVES)
def test_a_cut_self_motion_moves_the_best_point_to_the_best_free_one(panda, whole, objective):
    motion, T, pieces, branches = whole
    goal = sm.Objective(objective, Q if objective == "nearest" else None)
    top = sm.best(motion, T, goal, pieces, branches)[0]
    cut = top.parameter - 0.2  # "collides" above: the unconstrained best is not free
    free = lambda rows: np.asarray(rows)[:, motion.column] < cut  # noqa: E731
    b = best_free(motion, T, goal, free, pieces, branches)[0]
    assert b is not None and free(b.q[None])[0] and b.value < top.value
    # no free in-limit point of a dense sweep is better
    sweep = np.linspace(motion.lower, motion.upper, 2000)
    Qs, _, count, *_ = red.slices(motion, T, sweep[None], "respect")
    rows = Qs[0, :count[0]]
    rows = rows[free(rows)]
    assert b.value >= goal.values(motion, rows, motion.margins(rows)).max() - 1e-9
    # a solution at its parameter value, inside the limits, exact against Pinocchio
    assert b.q[motion.column] == pytest.approx(b.parameter, abs=1e-12) and motion.margins(b.q).min() >= -1e-9
    _exact(panda, LINK, b.q[None, None], [1], T)
    # where the unconstrained best is free, it is the answer
    same = best_free(motion, T, goal, lambda rows: np.ones(len(rows), bool), pieces, branches)[0]
    np.testing.assert_array_equal(same.q, top.q)


def test_avoid_collisions_with_redundancy(panda):
    T = kinematics.fk(panda, Q, links=[LINK]).poses[0, 0]
    free = collision_filter(panda, "avoid_collisions")
    best = kinematics.ik(panda, T, link=LINK, seed=Q, solutions="all", avoid_collisions=True,
                         redundancy={"select": "margin"})
    assert best.count[0] == 1 and free(best.q[0, :1])[0]
    values = {"values": np.linspace(-2.8, 2.8, 30)}
    every = kinematics.ik(panda, T, link=LINK, seed=Q, solutions="all", redundancy=values)
    kept = kinematics.ik(panda, T, link=LINK, seed=Q, solutions="all", redundancy=values, avoid_collisions=True)
    rows = every.q[0, :every.count[0]]
    assert kept.colliding[0] == int((~free(rows)).sum()) > 0
    assert kept.count[0] == every.count[0] - kept.colliding[0]
    np.testing.assert_array_equal(kept.q[0, :kept.count[0]], rows[free(rows)])
    np.testing.assert_array_equal(kept.parameter[0, :kept.count[0]], every.parameter[0, :every.count[0]][free(rows)])
    with pytest.raises(KinematicsError, match="intervals"):
        kinematics.ik(panda, T, link=LINK, solutions="all", avoid_collisions=True, redundancy={"intervals": True})
