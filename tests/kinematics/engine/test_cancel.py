"""Cancellation and time budgets (kinematics.engine.cancel): the same bits with a token, and work
that stops within a piece once the token trips (counted in checks made, not in wall-clock time)."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from kinematics import api
from kinematics.engine import cancel, parallel
from kinematics.errors import CancelledError, KinematicsError, TimeBudgetError


def _unreachable(model, n, seed=0):
    Q = model.sample_configurations(n, np.random.default_rng(seed))
    T = api.fk(model, Q, links=["tool0"]).poses[:, 0]
    T[:, :3, 3] *= 3.0
    return T


def test_results_are_the_same_bits_with_a_token(ur5):
    Q = ur5.sample_configurations(3 * cancel.CANCEL_PIECE_ROWS + 17, np.random.default_rng(1))
    T = api.fk(ur5, Q[:300], links=["tool0"]).poses[:, 0]
    plain = (api.fk(ur5, Q).poses, api.jacobian(ur5, Q).jacobians, api.velocity(ur5, Q, Q).twists,
             api.ik(ur5, T, link="tool0").solution, api.workspace(ur5, samples=70_000))
    token = api.Cancellation(timeout=600)
    for n in (1, 2):
        with parallel.threads(n), api.cancellable(token):
            got = (api.fk(ur5, Q).poses, api.jacobian(ur5, Q).jacobians, api.velocity(ur5, Q, Q).twists,
                   api.ik(ur5, T, link="tool0").solution, api.workspace(ur5, samples=70_000))
        np.testing.assert_array_equal(got[0], plain[0])
        np.testing.assert_array_equal(got[1], plain[1])
        for ref in plain[2]:
            np.testing.assert_array_equal(got[2][ref], plain[2][ref])
        np.testing.assert_array_equal(got[3].q, plain[3].q)
        np.testing.assert_array_equal(got[3].iterations, plain[3].iterations)
        np.testing.assert_array_equal(got[4].points, plain[4].points)
    assert token.checks > 10  # it was checked, piece by piece


def test_no_token_no_check(ur5):
    assert cancel.current() is None
    cancel.check()  # nothing to check
    with api.cancellable(None):
        api.fk(ur5, ur5.sample_configurations(20_000, np.random.default_rng(0)))


def test_a_cancelled_token_stops_before_any_work(ur5):
    token = api.Cancellation()
    token.cancel("the client disconnected")
    with api.cancellable(token), pytest.raises(CancelledError, match="the client disconnected"):
        api.ik(ur5, _unreachable(ur5, 400), link="tool0")
    assert token.checks == 1
    assert isinstance(CancelledError("x"), KinematicsError)


def test_the_time_budget_stops_ik_and_names_the_setting(ur5):
    T = _unreachable(ur5, 400)  # ~1,000 steps a target: far over 50 ms
    pieces = 400 // parallel.IK_PIECE_ROWS
    token = api.Cancellation(timeout=0.05, setting="KIN_REQUEST_TIMEOUT")
    with api.cancellable(token), pytest.raises(TimeBudgetError) as info:
        api.ik(ur5, T, link="tool0", restarts=1000)
    assert info.value.setting == "KIN_REQUEST_TIMEOUT" and info.value.limit == 0.05
    assert "KIN_REQUEST_TIMEOUT" in str(info.value) and "0.05 s" in str(info.value)
    assert token.checks < pieces  # it stopped part of the way


def test_cancel_from_another_thread_stops_the_work(ur5):
    """What a server does when its client disconnects: cancel while the work runs."""
    T = _unreachable(ur5, 400)
    token = api.Cancellation()
    outcome = {}

    def work():
        try:
            with api.cancellable(token):
                api.ik(ur5, T, link="tool0", restarts=1000)
            outcome["done"] = True
        except CancelledError as exc:
            outcome["cancelled"] = exc

    t = threading.Thread(target=work)
    t.start()
    while token.checks < 2:  # it is running
        time.sleep(0.005)
    token.cancel("the client disconnected")
    t.join(60)
    assert "cancelled" in outcome and token.checks < 400 // parallel.IK_PIECE_ROWS


def test_workspace_and_velocity_stop(ur5):
    token = api.Cancellation()
    token.cancel()
    with api.cancellable(token):
        with pytest.raises(CancelledError):
            api.workspace(ur5, samples=200_000)
        Q = ur5.sample_configurations(2 * cancel.CANCEL_PIECE_ROWS, np.random.default_rng(0))
        with pytest.raises(CancelledError):
            api.velocity(ur5, Q, Q)
        with pytest.raises(CancelledError):
            api.jacobian(ur5, Q)


def test_remaining_and_expired():
    token = api.Cancellation(timeout=1000)
    assert 999 < token.remaining() <= 1000 and not token.expired and token.error() is None
    assert api.Cancellation().remaining() is None
    late = api.Cancellation(timeout=1e-9)
    time.sleep(0.001)
    assert late.expired and isinstance(late.error(), TimeBudgetError)
