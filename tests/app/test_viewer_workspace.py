"""The viewer's framing (the camera fits the whole model at load and on "Fit"), its Workspace tab
(the sampled cloud) and the velocity arrows, in a real headless Chromium (see test_viewer.py)."""

from __future__ import annotations

import httpx
import numpy as np
import pytest

from tests.app.test_viewer import ARTIFACTS, _open, _severe_console, _state, _wait, browser, needs_browser, server  # noqa: F401

#: window sizes the framing must work at
SIZES = [(1400, 1000), (800, 600)]
#: models of different shapes: an arm, an arm with a hand, a DH preset, a humanoid
FRAMED_MODELS = ["ur5", "panda", "scara", "talos_reduced"]
#: the projected model spans at least this fraction of the canvas's smaller side (fitted, not tiny)
MIN_SPAN = 0.25


def _size(driver, width: int, height: int) -> None:
    """The page's viewport at exactly width x height CSS pixels (a headless window cannot grow past
    its screen, so the viewport is set through the DevTools protocol instead of the window)."""
    driver.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",
                           {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False})
    _wait(driver, lambda d: d.execute_script("return [window.innerWidth, window.innerHeight]") == [width, height],
          f"the viewport at {width}x{height}")


def _projection(driver) -> dict:
    return driver.execute_script("return window.viewerTest.projectLinks()")


def _outside(projection: dict) -> list[str]:
    w, h = projection["width"], projection["height"]
    return [link for link, (x, y, z) in projection["points"].items()
            if not (0 <= x <= w and 0 <= y <= h and -1 < z < 1)]


@pytest.fixture
def sized(browser):
    yield browser
    browser.execute_cdp_cmd("Emulation.clearDeviceMetricsOverride", {})


@needs_browser
@pytest.mark.parametrize("width, height", SIZES)
@pytest.mark.parametrize("model_id", FRAMED_MODELS)
def test_the_whole_model_is_in_view_when_loaded(server, sized, model_id, width, height):
    driver = sized
    _size(driver, width, height)
    _open(driver, f"{server}/viewer/{model_id}")
    projection = _projection(driver)
    info = httpx.get(f"{server}/models/{model_id}").json()
    assert set(projection["points"]) == set(info["links"])
    assert projection["width"] > 100 and projection["height"] > 100, projection
    assert _outside(projection) == [], f"{model_id} at {width}x{height}: links outside the canvas"
    xy = np.array([p[:2] for p in projection["points"].values()])
    span = (xy.max(axis=0) - xy.min(axis=0)).max()
    assert span >= MIN_SPAN * min(projection["width"], projection["height"]), "the model is drawn too small"
    ARTIFACTS.mkdir(exist_ok=True)
    driver.save_screenshot(str(ARTIFACTS / f"viewer_fit_{model_id}_{width}x{height}.png"))
    assert _severe_console(driver) == []


@needs_browser
def test_the_fit_button_frames_the_model_again(server, sized):
    driver = sized
    _size(driver, *SIZES[1])
    _open(driver, f"{server}/viewer/talos_reduced")
    # zoom close to one foot: most of the humanoid leaves the view
    foot = driver.execute_script("return window.viewerTest.projectLinks()")  # noqa: F841 - warm the hook
    driver.execute_script("window.viewerTest.moveCamera([0.3, -0.3, -0.8], [0.0, -0.1, -0.9])")
    _wait(driver, lambda d: len(_outside(_projection(d))) > 5, "the camera to leave the model")
    fits = _state(driver)["fits"]
    driver.find_element("id", "btn-fit").click()
    _wait(driver, lambda d: _state(d)["fits"] > fits, "the fit")
    assert _outside(_projection(driver)) == []


@needs_browser
def test_workspace_tab_draws_the_cloud(server, sized):
    driver = sized
    _open(driver, f"{server}/viewer/ur5")
    driver.find_element("css selector", '.tabs button[data-tab="workspace"]').click()
    assert driver.find_element("id", "tab-workspace").is_displayed()
    link = _state(driver)["selectedLink"]
    ws = driver.execute_async_script(
        "const done = arguments[arguments.length - 1]; window.viewerTest.sampleWorkspace(4000).then(done);")
    assert ws["samples"] == 4000 and ws["link"] == link
    summary = httpx.post(f"{server}/models/ur5/workspace", json={"link": link, "samples": 4000}).json()
    assert ws["maxManipulability"] == pytest.approx(summary["manipulability"]["max"], rel=1e-12)
    assert ws["reach"] == summary["reach"]
    assert "4000 samples" in driver.find_element("id", "ws-status").text
    assert driver.execute_script("return !!window.viewerTest && document.getElementById('ws-colorbar').hidden") is False
    ARTIFACTS.mkdir(exist_ok=True)
    driver.save_screenshot(str(ARTIFACTS / "viewer_workspace_ur5.png"))
    driver.find_element("id", "ws-clear").click()
    assert _state(driver)["workspace"] is None
    assert _severe_console(driver) == []


@needs_browser
def test_velocity_arrows_follow_the_joint_velocities(server, sized):
    driver = sized
    _open(driver, f"{server}/viewer/ur5")
    driver.find_element("css selector", '.tabs button[data-tab="workspace"]').click()
    qdot = [0.5, -0.2, 0.3, 0.0, 0.4, 1.0]
    velocity = driver.execute_async_script(
        "const done = arguments[arguments.length - 1]; window.viewerTest.setQdot(arguments[0]).then(done);", qdot)
    q = velocity["q"]
    expected = httpx.post(f"{server}/models/ur5/velocity", json={"q": q, "qdot": qdot}).json()["velocities"]
    for link, v in expected.items():
        np.testing.assert_allclose(velocity["linear"][link], v["linear"], atol=1e-12)
    moving = sum(np.linalg.norm(v["linear"]) > 1e-9 for v in expected.values())
    assert _state(driver)["velocityArrows"] == moving > 3
    ARTIFACTS.mkdir(exist_ok=True)
    driver.save_screenshot(str(ARTIFACTS / "viewer_velocity_ur5.png"))
    # moving a joint keeps the arrows on the links: a new velocity request after the FK answer
    before = _state(driver)["velocityRequests"]
    driver.execute_script(
        """const input = document.querySelector('#sliders input[data-joint="elbow_joint"]');
           input.value = '0.7'; input.dispatchEvent(new Event('input', {bubbles: true}));""")
    _wait(driver, lambda d: _state(d)["velocityRequests"] > before
          and _state(d)["velocityResponses"] == _state(d)["velocityRequests"]
          and _state(d)["lastVelocity"]["q"][2] == pytest.approx(0.7, abs=1e-3), "the arrows after a joint move")
    driver.execute_async_script(
        "const done = arguments[arguments.length - 1]; window.viewerTest.setQdot([0, 0, 0, 0, 0, 0]).then(done);")
    assert _state(driver)["velocityArrows"] == 0
    assert _severe_console(driver) == []
