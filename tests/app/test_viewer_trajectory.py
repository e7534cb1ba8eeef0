"""The viewer's trajectory of a Cartesian path (app/static/viewer/trajectory.js), in a real headless
Chromium (see test_viewer.py): the page times the planned path's q with POST /trajectory, plays the
arm along `t` to the last sample, and charts each joint's velocity and acceleration against its limit."""

from __future__ import annotations

import httpx
import numpy as np
import pytest

from tests.app.test_viewer import (_docs_screenshot, _severe_console, _state, _wait, browser,  # noqa: F401
                                   needs_browser, server)
from tests.app.test_viewer_ghosts import _js, _plan_a_path, _settled

try:
    from selenium.webdriver.common.by import By
except ImportError:  # pragma: no cover - needs_browser skips the tests
    pass


@needs_browser
def test_a_planned_path_is_timed_played_in_time_and_charted(server, browser):
    _plan_a_path(server, browser)
    assert _js(browser, "window.viewerState.path.rows") > 2
    path_q = _js(browser, "window.viewerState.path.q")

    for field, value in (("traj-velocity", "0.8"), ("traj-acceleration", "1.5")):
        box = browser.find_element(By.ID, field)
        box.clear()
        box.send_keys(value)
    browser.find_element(By.ID, "traj-time").click()
    _wait(browser, lambda d: _state(d)["trajectoryResponses"] >= 1 and (_js(d, "window.viewerState.trajectory")
                                                                        is not None), "the timed path")
    got = _js(browser, "window.viewerState.trajectory")
    # the same request to the service: the page shows its answer
    api = httpx.post(f"{server}/models/ur5/trajectory", json={
        "waypoints": path_q, "limits": {"velocity": 0.8, "acceleration": 1.5}, "rate": 50}).json()
    assert got["duration"] == api["duration"] and got["samples"] == len(api["t"]) > 10
    assert got["waypoints"] == len(path_q) and got["method"] == api["method"]
    assert got["limits"]["velocity"] == [0.8] * 6 and got["limits"]["acceleration"] == [1.5] * 6
    # the chart's peaks are the answer's, within the limits and one of them at it (time-optimal)
    v = np.max(np.abs(np.asarray(api["qd"]) / 0.8))
    a = np.max(np.abs(np.asarray(api["qdd"]) / 1.5))
    assert got["velocityRatio"] == pytest.approx(v, rel=1e-12) and got["accelerationRatio"] == pytest.approx(a, rel=1e-12)
    assert max(v, a) <= 1 + 1e-6 and max(v, a) > 0.9
    assert browser.find_element(By.ID, "traj-chart").is_displayed()
    assert _js(browser, "window.viewerTest.trajectoryChartInk()") > 2000
    assert "s through" in browser.find_element(By.ID, "traj-status").text

    # play in time to the last sample: the sliders end at the trajectory's last q (the path's end)
    browser.find_element(By.ID, "traj-play").click()
    _wait(browser, lambda d: _js(d, "window.viewerState.trajectory.playing") is True
          or _js(d, "window.viewerState.trajectory.sample") > 0, "the playback started")
    _wait(browser, lambda d: not _js(d, "window.viewerState.trajectory.playing")
          and _js(d, "window.viewerState.trajectory.sample") == len(api["t"]) - 1, "the playback at its last sample")
    _settled(browser)
    q = _js(browser, "window.viewerTest.sliderValues()")
    assert q == pytest.approx(api["q"][-1], abs=1e-12)
    assert q == pytest.approx(path_q[-1], abs=1e-9)
    assert _js(browser, "window.viewerState.trajectory.t") == api["duration"]
    browser.execute_script("document.getElementById('traj-chart').scrollIntoView({block: 'end'})")
    _docs_screenshot(browser, "viewer_trajectory.png")

    # without a planned path: the page says what is missing and asks nothing
    browser.find_element(By.ID, "path-clear").click()
    browser.find_element(By.ID, "traj-time").click()
    assert "Plan a Cartesian path first" in browser.find_element(By.ID, "traj-status").text
    assert _state(browser)["trajectoryRequests"] == 1
    assert not _severe_console(browser)
