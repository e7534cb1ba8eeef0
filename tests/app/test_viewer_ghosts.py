"""The viewer's every-solution ghosts, Cartesian path playback and calibration residual chart, in a
real headless Chromium (see test_viewer.py): what the page shows is what the service answers."""

from __future__ import annotations

import httpx
import numpy as np
import pytest

from tests.app.test_viewer import (UR5_Q_KNOWN, _docs_screenshot, _enable_ik, _open, _quaternion,  # noqa: F401
                                   _severe_console, _state, _ur5_fk, _wait, browser, needs_browser, server)

try:
    from selenium.webdriver.common.actions.action_builder import ActionBuilder
    from selenium.webdriver.common.by import By
except ImportError:  # pragma: no cover - needs_browser skips the tests
    pass

#: a UR5 configuration whose pose has 8 solutions, some of them in self-collision (found by search
#: with POST /ik and POST /collision; the test checks both properties against the service)
UR5_Q_GHOSTS = [-2.45, -1.87, 2.36, -1.17, -1.18, 0.48]
#: the path's second waypoint: the first one moved this far (metres, world frame)
PATH_OFFSET = [0.0, -0.25, 0.1]
#: a waypoint out of the UR5's reach (about 0.95 m)
FAR_POSITION = [2.5, 0.0, 0.4]


def _js(driver, script: str, *args):
    return driver.execute_script(f"return {script}", *args)


def _target_of(q) -> tuple[list[float], dict]:
    T = _ur5_fk(q)
    return T[:3, 3].tolist(), _quaternion(T)


def _ik_to(driver, position, quaternion) -> dict:
    return _js(driver, "window.viewerTest.ikTo(arguments[0], arguments[1])", position, quaternion)


def _settled(driver) -> None:
    driver.execute_async_script("window.viewerTest.whenSettled().then(arguments[arguments.length - 1])")


def _ghosts_for(driver, target_q) -> dict:
    """The page's ghosts once every request about the target at FK(target_q) is answered."""
    position, quaternion = _target_of(target_q)
    _ik_to(driver, position, quaternion)
    _wait(driver, lambda d: (_js(d, "window.viewerState.ghosts") or {}).get("count") is not None
          and not _state(d)["ghostBusy"], "the ghosts of the target")
    return _js(driver, "window.viewerState.ghosts")


@needs_browser
def test_ghosts_are_every_solution_and_a_click_takes_one(server, browser):
    _open(browser, f"{server}/viewer/ur5")
    browser.find_element(By.CSS_SELECTOR, '#link-list option[value="tool0"]').click()
    _wait(browser, lambda d: _state(d)["selectedLink"] == "tool0", "tool0 selected")
    _enable_ik(browser)
    ghosts = _ghosts_for(browser, UR5_Q_GHOSTS)

    # the same request to the service: the page draws exactly its solutions
    position, quaternion = _target_of(UR5_Q_GHOSTS)
    seed = ghosts["seed"]                                      # the joint values when the page asked
    api = httpx.post(f"{server}/models/ur5/ik", json={
        "link": "tool0", "target": {"position": position, "quaternion": quaternion}, "solutions": "all",
        "limits": "ignore", "seed": seed}).json()
    assert api["count"] == 8                                   # a UR5 pose off its singularities
    assert ghosts["count"] == api["count"] and ghosts["drawn"] == api["count"]
    assert ghosts["family"] == "three_parallel"
    assert _js(browser, "document.querySelectorAll('#ghost-list button').length") == api["count"]
    assert f"{api['count']} solutions" in browser.find_element(By.ID, "ghost-status").text
    assert "three_parallel" in browser.find_element(By.ID, "ghost-status").text
    assert np.allclose([s["q"] for s in ghosts["solutions"]], [s["q"] for s in api["solutions"]], atol=1e-12)
    # ur5 has collision geometry: every ghost is checked, as POST /collision says
    colliding = httpx.post(f"{server}/models/ur5/collision", json={"q": [s["q"] for s in api["solutions"]]}).json()
    assert [s["colliding"] for s in ghosts["solutions"]] == colliding["colliding"]
    assert 0 < sum(colliding["colliding"]) < api["count"]
    assert [s["color"] for s in ghosts["solutions"]] == ["#d62728" if c else "#3b82f6" for c in colliding["colliding"]]
    assert f"{sum(colliding['colliding'])} colliding" in browser.find_element(By.ID, "ghost-status").text

    # a real click on a ghost (a point where it is the first one hit) makes it the configuration
    current = np.asarray(_js(browser, "window.viewerTest.sliderValues()"))
    index = max(range(api["count"]), key=lambda i: np.abs(np.asarray(api["solutions"][i]["q"]) - current).max())
    points = _js(browser, "window.viewerTest.ghostPoints(arguments[0])", index)
    assert points, "no point of the ghost is in view"
    click = ActionBuilder(browser, duration=20)
    click.pointer_action.move_to_location(int(round(points[0]["x"])), int(round(points[0]["y"])))
    click.pointer_action.pointer_down()
    click.pointer_action.pointer_up()
    click.perform()
    _wait(browser, lambda d: (_js(d, "window.viewerState.ghosts") or {}).get("chosen") == index, "the ghost chosen")
    _settled(browser)
    q = _js(browser, "window.viewerTest.sliderValues()")
    assert q == pytest.approx(api["solutions"][index]["q"], abs=1e-12)
    assert _state(browser)["lastQ"] == pytest.approx(q, abs=0)   # and drawn
    T = _ur5_fk(q)
    assert np.allclose(T[:3, 3], position, atol=1e-9)          # it still reaches the target
    fits = _state(browser)["fits"]
    browser.find_element(By.ID, "btn-fit").click()             # frames the ghosts too
    _wait(browser, lambda d: _state(d)["fits"] > fits, "the fit")
    projection = _js(browser, "window.viewerTest.projectLinks()")
    assert all(0 <= x <= projection["width"] and 0 <= y <= projection["height"]
               for x, y, _ in projection["points"].values())
    _docs_screenshot(browser, "viewer_ik_ghosts.png")
    assert _severe_console(browser) == []


def _plan_a_path(server, browser) -> tuple[list[float], list[float], dict, list[float]]:
    """The UR5 page with a Cartesian path of tool0 planned from FK(UR5_Q_KNOWN), PATH_OFFSET long:
    ``(start, end, quaternion, seed)``."""
    _open(browser, f"{server}/viewer/ur5")
    browser.find_element(By.CSS_SELECTOR, '#link-list option[value="tool0"]').click()
    _wait(browser, lambda d: _state(d)["selectedLink"] == "tool0", "tool0 selected")
    _enable_ik(browser)
    browser.find_element(By.ID, "ghost-enable").click()        # ghosts off: the path alone
    browser.find_element(By.CSS_SELECTOR, "#path-panel summary").click()
    start, quaternion = _target_of(UR5_Q_KNOWN)
    _ik_to(browser, start, quaternion)
    seed = _js(browser, "window.viewerTest.sliderValues()")
    browser.find_element(By.ID, "path-add").click()
    end = (np.asarray(start) + PATH_OFFSET).tolist()
    _ik_to(browser, end, quaternion)
    browser.find_element(By.ID, "path-add").click()
    assert _js(browser, "window.viewerState.path.waypoints") == 2
    browser.find_element(By.ID, "path-plan").click()
    _wait(browser, lambda d: (_js(d, "window.viewerState.path") or {}).get("rows", 0) > 0
          and not _js(d, "window.viewerState.path.playing") and _state(d)["pathResponses"] >= 1, "the planned path")
    return start, end, quaternion, seed


@needs_browser
def test_a_path_is_planned_played_to_its_end_and_its_stop_is_marked(server, browser):
    start, end, quaternion, seed = _plan_a_path(server, browser)

    waypoints = [{"position": p, "quaternion": quaternion} for p in (start, end)]
    api = httpx.post(f"{server}/models/ur5/ik/path",
                     json={"link": "tool0", "waypoints": waypoints, "seed": seed}).json()
    path = _js(browser, "window.viewerState.path")
    assert api["complete"] and path["complete"]
    assert path["rows"] == len(api["q"]) > 2
    assert np.allclose(path["q"], api["q"], atol=1e-12)
    assert "Complete" in browser.find_element(By.ID, "path-status").text

    browser.find_element(By.ID, "path-play").click()
    _wait(browser, lambda d: not _js(d, "window.viewerState.path.playing")
          and _js(d, "window.viewerState.path.row") == len(api["q"]) - 1, "the playback at its last row")
    _settled(browser)
    q = _js(browser, "window.viewerTest.sliderValues()")
    assert q == pytest.approx(api["q"][-1], abs=1e-12)
    assert _state(browser)["lastQ"] == pytest.approx(q, abs=0)
    assert np.allclose(_ur5_fk(q)[:3, 3], end, atol=1e-6)
    assert browser.find_element(By.ID, "path-row-label").text == f"{len(api['q'])} / {len(api['q'])}"

    # a third waypoint out of reach: the path stops where the service says, and the page says why
    _ik_to(browser, FAR_POSITION, quaternion)
    browser.find_element(By.ID, "path-add").click()
    browser.find_element(By.ID, "path-plan").click()
    _wait(browser, lambda d: (_js(d, "window.viewerState.path") or {}).get("stopped") is not None, "the stopped path")
    path = _js(browser, "window.viewerState.path")
    api = httpx.post(f"{server}/models/ur5/ik/path", json={
        "link": "tool0", "waypoints": waypoints + [{"position": FAR_POSITION, "quaternion": quaternion}],
        "seed": seed}).json()
    assert path["stopped"] == api["stopped"] and api["stopped"]["reason"] == "unreachable"
    assert path["rows"] == len(api["q"])
    status = browser.find_element(By.ID, "path-status").text
    assert f"Stopped at target {api['stopped']['index']}" in status and "unreachable" in status
    assert _js(browser, "!!window.viewerTest.pathStopMarker()")
    assert _severe_console(browser) == []


@needs_browser
def test_the_calibration_tab_draws_a_bar_per_measurement(server, browser):
    _open(browser, f"{server}/viewer/ur5")
    browser.find_element(By.CSS_SELECTOR, '.tabs button[data-tab="calibration"]').click()
    browser.find_element(By.ID, "cal-example").click()
    _wait(browser, lambda d: d.find_element(By.ID, "cal-measurements").get_attribute("value").startswith("["),
          "the example measurements")
    browser.find_element(By.ID, "cal-run").click()
    _wait(browser, lambda d: _state(d)["calResponses"] >= 1 and _state(d)["calibration"], "the calibration answer")
    cal = _js(browser, "window.viewerState.calibration")
    assert "error" not in cal, cal
    spec = httpx.get(f"{server}/openapi.json").json()
    example = spec["paths"]["/models/{model_id}/calibrate"]["post"]["requestBody"]["content"]["application/json"][
        "examples"]["ur5_positions"]["value"]
    n = len(example["measurements"])
    assert cal["measurements"] == n and cal["bars_before"] == n and cal["bars_after"] == n
    assert _js(browser, "document.querySelectorAll('#cal-chart svg rect.bar-after.held-out[data-index]').length") \
        == len(cal["holdout"]) > 0
    # the bars are the answer's residuals: after much lower than before on a log scale
    assert cal["rmse_after"] < cal["rmse_before"] / 10
    heights = _js(browser, "[...document.querySelectorAll('#cal-chart rect[data-index]')].map(r => "
                           "[r.getAttribute('class'), +r.getAttribute('height')])")
    before = [h for c, h in heights if c == "bar-before"]
    after = [h for c, h in heights if c.startswith("bar-after")]
    assert min(before) > max(after) > 0
    assert "calibrated model" in browser.find_element(By.ID, "cal-summary").text

    # the same measurements as CSV (sent as text/csv, the options as query parameters): the same answer
    names = httpx.get(f"{server}/models/ur5").json()["joint_names"]
    csv = "\n".join([",".join(names + ["x", "y", "z"])] + [
        ",".join(str(v) for v in m["q"] + m["position"]) for m in example["measurements"]])
    browser.execute_script("document.getElementById('cal-measurements').value = arguments[0]", csv)
    browser.find_element(By.ID, "cal-run").click()
    _wait(browser, lambda d: _state(d)["calResponses"] >= 2, "the CSV calibration answer")
    again = _js(browser, "window.viewerState.calibration")
    assert "error" not in again, again
    assert again["bars_after"] == n and again["rmse_after"] == pytest.approx(cal["rmse_after"], rel=1e-9)
    assert again["residuals"]["before"] == pytest.approx(cal["residuals"]["before"], rel=1e-9)

    browser.find_element(By.ID, "btn-fit").click()             # the wider panel left the arm off-centre
    _docs_screenshot(browser, "viewer_calibration.png")
    assert _severe_console(browser) == []


@needs_browser
def test_a_redundant_arm_shows_its_self_motion_and_with_a_joint_locked_its_ghosts(server, browser):
    _open(browser, f"{server}/viewer/panda")
    link = "panda_hand_tcp"                                    # joints 1-7 (the default leaf is a finger)
    browser.find_element(By.CSS_SELECTOR, f'#link-list option[value="{link}"]').click()
    _wait(browser, lambda d: _state(d)["selectedLink"] == link, f"{link} selected")
    _enable_ik(browser)
    # 7 free joints and none locked: the self-motion (test_viewer_redundancy.py), its slider shown
    _wait(browser, lambda d: (_js(d, "window.viewerState.selfMotion") or {}).get("count") is not None,
          "the self-motion of the target")
    _settled(browser)
    assert _js(browser, "window.viewerState.selfMotion")["joint"] == "panda_joint7"
    assert not browser.find_element(By.ID, "sm-panel").get_attribute("hidden")
    assert _state(browser)["lastError"] is None

    from selenium.webdriver.support.ui import Select

    Select(browser.find_element(By.ID, "ghost-locked")).select_by_value("panda_joint7")
    _wait(browser, lambda d: ((_js(d, "window.viewerState.ghosts") or {}).get("locked") or {}).get("panda_joint7")
          is not None and not _state(d)["ghostBusy"], "the ghosts with panda_joint7 locked")
    ghosts = _js(browser, "window.viewerState.ghosts")
    assert _js(browser, "window.viewerState.selfMotion") is None   # a finite set: no self-motion
    assert browser.find_element(By.ID, "sm-panel").get_attribute("hidden")
    target = _js(browser, "window.viewerTest.targetPose()")
    api = httpx.post(f"{server}/models/panda/ik", json={
        "link": link, "target": target, "solutions": "all", "limits": "ignore", "seed": ghosts["seed"],
        "locked": ghosts["locked"]}).json()
    assert ghosts["count"] == api["count"] > 0
    assert ghosts["family"] == api["family"]
    assert np.allclose([s["q"] for s in ghosts["solutions"]], [s["q"] for s in api["solutions"]], atol=1e-12)
    assert _severe_console(browser) == []
