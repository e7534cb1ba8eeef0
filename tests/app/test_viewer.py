"""The model viewer page (app/routes/viewer.py, app/static/viewer/) in a real headless Chromium.

A real uvicorn serves the app on a loopback port with a temporary data directory; the
system Chromium (Debian packages ``chromium`` and ``chromium-driver``, installed by
``.ci/run``) is driven by selenium through ``/usr/bin/chromedriver`` (nothing is
downloaded). Without them the browser tests are skipped, saying why.

Screenshots are written to ``tests/artifacts/`` (not committed).
"""

from __future__ import annotations

import io
import json
import os
import re
import time
from pathlib import Path

import httpx
import numpy as np
import pytest

from tests.live import LiveServer
from tests.paths import REPO, TESTS

CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")
ARTIFACTS = TESTS / "artifacts"  # screenshots; ignored by git (tests/artifacts/.gitignore)

#: seconds to wait for the page to reach a state
PAGE_TIMEOUT = 60.0
#: a rendered model: grey-level standard deviation of the canvas well above a flat colour
MIN_CANVAS_STD = 4.0
#: a joint move redraws the arm: at least this fraction of canvas pixels change
MIN_CHANGED_FRACTION = 0.002
#: the pose panel prints 4 decimals
PANEL_DECIMALS = 4
WINDOW_SIZE = (1400, 860)

try:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select, WebDriverWait
except ImportError:  # pragma: no cover - the test extra installs it
    webdriver = None


def _skip_reason() -> str | None:
    if webdriver is None:
        return "selenium is not installed (pip install -e '.[test]')"
    missing = [str(p) for p in (CHROMIUM, CHROMEDRIVER) if not p.exists()]
    if missing:
        return (f"headless Chromium not available ({', '.join(missing)} missing): "
                "apt-get install chromium chromium-driver (.ci/run does this)")
    return None


needs_browser = pytest.mark.skipif(_skip_reason() is not None, reason=_skip_reason() or "")


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """Base URL of a uvicorn serving ``app.main:app`` with an empty temporary data directory (the
    page checks self-collision as it moves: allowed-collision matrices from few samples, quick)."""
    tmp = tmp_path_factory.mktemp("viewer")
    with LiveServer(tmp / "data", tmp / "uvicorn.log", env={"KIN_COLLISION_SAMPLES": "500"}) as live:
        yield live.url


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    """A headless system Chromium (software WebGL); downloads go to a temporary directory."""
    reason = _skip_reason()
    if reason:
        pytest.skip(reason)
    profile = tmp_path_factory.mktemp("chromium-profile")
    downloads = tmp_path_factory.mktemp("downloads")
    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for flag in (
        "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--disable-quic",
        "--no-first-run", "--disable-background-networking", "--disable-component-update", "--disable-sync",
        "--disable-extensions", "--disable-default-apps", "--use-gl=angle", "--use-angle=swiftshader",
        "--enable-unsafe-swiftshader", f"--user-data-dir={profile}",
        f"--window-size={WINDOW_SIZE[0]},{WINDOW_SIZE[1]}", "--force-device-scale-factor=1",
    ):
        options.add_argument(flag)
    options.add_experimental_option("prefs", {
        "download.default_directory": str(downloads), "download.prompt_for_download": False,
    })
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    # An explicit driver and browser path: selenium-manager has nothing to look up or download.
    driver = webdriver.Chrome(service=Service(str(CHROMEDRIVER)), options=options)
    driver.execute_cdp_cmd("Browser.setDownloadBehavior", {"behavior": "allow", "downloadPath": str(downloads)})
    driver.downloads = downloads
    driver.set_script_timeout(PAGE_TIMEOUT)
    try:
        yield driver
    finally:
        driver.quit()


def _wait(driver, predicate, what: str):
    try:
        return WebDriverWait(driver, PAGE_TIMEOUT, poll_frequency=0.1).until(lambda d: predicate(d))
    except Exception as exc:  # TimeoutException: say what we waited for and what the page says
        state = driver.execute_script("return JSON.stringify(window.viewerState || null)")
        error = driver.execute_script("const e = document.getElementById('error-text'); return e && e.textContent")
        raise AssertionError(f"timed out waiting for {what}; viewerState={state}; page error={error!r}") from exc


def _state(driver) -> dict:
    return driver.execute_script("return window.viewerState")


def _open(driver, url: str) -> None:
    driver.get_log("browser")  # drop what earlier tests left in the console log
    driver.get(url)
    _wait(driver, lambda d: d.execute_script("return !!(window.viewerState && window.viewerState.ready)"),
          "viewerState.ready")


def _frames_drawn(driver, count: int = 2) -> None:
    """Return once the page has run ``count`` more animation frames (a change made before is drawn)."""
    driver.execute_async_script(
        "const done = arguments[arguments.length - 1]; let n = arguments[0];"
        "const step = () => (--n <= 0 ? done() : requestAnimationFrame(step)); requestAnimationFrame(step);", count)


def _docs_screenshot(driver, artifact: str) -> None:
    """Once the page's last change is drawn: a screenshot saved as ``ARTIFACTS / artifact``. The tests
    never write a tracked file: ``make docs-images`` (scripts/refresh_docs_images.py) runs them and
    copies these shots to the pictures the documentation shows."""
    _frames_drawn(driver)
    ARTIFACTS.mkdir(exist_ok=True)
    driver.save_screenshot(str(ARTIFACTS / artifact))


def _changed_fraction(before, after) -> float:
    """The fraction of the canvas's pixels that differ visibly between two images."""
    return float((np.abs(np.asarray(after, dtype=int) - np.asarray(before, dtype=int)).sum(axis=2) > 30).mean())


def _canvas_image(driver):
    from PIL import Image

    canvas = driver.find_element(By.CSS_SELECTOR, "#canvas-host canvas")
    return Image.open(io.BytesIO(canvas.screenshot_as_png)).convert("RGB")


def _set_slider(driver, joint: str, value: float) -> None:
    driver.execute_script(
        """const input = document.querySelector(`#sliders input[data-joint="${arguments[0]}"]`);
           input.value = String(arguments[1]);
           input.dispatchEvent(new Event('input', {bubbles: true}));""",
        joint, value,
    )


def _panel(driver) -> dict[str, str]:
    ids = ("pose-link", "pose-position", "pose-quaternion", "pose-rpy", "pose-manipulability")
    return {i: driver.find_element(By.ID, i).text for i in ids}


def _numbers(text: str) -> np.ndarray:
    return np.array([float(x) for x in text.split(",")])


def _severe_console(driver) -> list[str]:
    return [e["message"] for e in driver.get_log("browser") if e["level"] == "SEVERE"]


@needs_browser
def test_ur5_draws_moves_and_reports_the_pose(server, browser):
    _open(browser, f"{server}/viewer/ur5")
    info = httpx.get(f"{server}/models/ur5").json()

    # one slider per entry of q, named and bounded by the model's limits
    sliders = browser.execute_script(
        "return [...document.querySelectorAll('#sliders input')].map(i => [i.dataset.joint, +i.min, +i.max])")
    assert [s[0] for s in sliders] == info["joint_names"]
    joints = {j["name"]: j for j in info["joints"]}
    for name, lo, hi in sliders:
        lim = joints[name]["limits"]
        expected = (lim["lower"], lim["upper"]) if lim else (-np.pi, np.pi)
        assert (lo, hi) == pytest.approx(expected), name
    # the link list holds every link; the panel shows the deepest leaf (the tool)
    links = browser.execute_script("return [...document.querySelectorAll('#link-list option')].map(o => o.value)")
    assert links == info["links"]
    before_panel = _panel(browser)
    selected = before_panel["pose-link"]
    assert selected in info["links"] and selected != info["root"]

    before = _canvas_image(browser)
    ARTIFACTS.mkdir(exist_ok=True)
    browser.save_screenshot(str(ARTIFACTS / "viewer_ur5_before.png"))
    grey = np.asarray(before.convert("L"), dtype=float)
    assert grey.std() > MIN_CANVAS_STD, f"canvas looks blank (std {grey.std():.2f})"

    requests_before = _state(browser)["fkRequests"]
    _set_slider(browser, "shoulder_lift_joint", -1.2)
    _set_slider(browser, "elbow_joint", 1.0)
    _set_slider(browser, "wrist_2_joint", 0.8)  # off the wrist singularity (wrist_2 = 0)
    _wait(browser, lambda d: _panel(d)["pose-position"] != before_panel["pose-position"], "the pose panel to change")
    # the last FK answer: the one for the sliders' final values (an FK request queued behind the
    # first is sent once that answer is drawn, so equal counts alone may come too early)
    _wait(browser, lambda d: _state(d)["fkResponses"] == _state(d)["fkRequests"] and _state(d)["lastQ"] == d.execute_script(
        "return [...document.querySelectorAll('#sliders input')].map(i => +i.value)"), "the last FK answer")
    state = _state(browser)
    assert state["fkRequests"] > requests_before

    # the panel agrees with the service's own FK at the sliders' values
    q = state["lastQ"]
    assert q == pytest.approx(browser.execute_script(
        "return [...document.querySelectorAll('#sliders input')].map(i => +i.value)"), abs=1e-12)
    assert q[1] == pytest.approx(-1.2, abs=1e-2) and q[2] == pytest.approx(1.0, abs=1e-2)
    assert q[4] == pytest.approx(0.8, abs=1e-2)
    fk = httpx.post(f"{server}/models/ur5/fk", json={"q": q, "links": [selected]}).json()["poses"][selected]
    _wait(browser, lambda d: _panel(d)["pose-manipulability"] not in ("", "-")
          and _state(d)["lastPose"].get("manipulability") is not None, "the manipulability")
    after_panel = _panel(browser)
    tol = 10 ** -PANEL_DECIMALS
    np.testing.assert_allclose(_numbers(after_panel["pose-position"]), fk["position"], atol=tol)
    quat = fk["quaternion"]
    np.testing.assert_allclose(_numbers(after_panel["pose-quaternion"]),
                               [quat["w"], quat["x"], quat["y"], quat["z"]], atol=tol)
    np.testing.assert_allclose(_numbers(after_panel["pose-rpy"]), fk["rpy"], atol=tol)
    jac = httpx.post(f"{server}/models/ur5/jacobian",
                     json={"q": q, "link": selected, "reference": "local_world_aligned"}).json()
    assert jac["manipulability"] > 1e-3  # a regular configuration: the comparison below means something
    assert float(after_panel["pose-manipulability"]) == pytest.approx(jac["manipulability"], abs=1e-6)

    # the drawing moved with the arm
    after = _canvas_image(browser)
    browser.save_screenshot(str(ARTIFACTS / "viewer_ur5_after.png"))
    diff = np.abs(np.asarray(after, dtype=int) - np.asarray(before, dtype=int)).sum(axis=2) > 30
    assert diff.mean() > MIN_CHANGED_FRACTION, f"only {diff.mean():.4%} of the canvas changed"

    # nothing came from outside the service; the vendored three.js was loaded from it
    resources = browser.execute_script("return performance.getEntriesByType('resource').map(e => e.name)")
    assert all(r.startswith(server + "/") for r in resources), resources
    assert any(r.endswith("/vendor/three.module.js") for r in resources)
    assert any(r.endswith("/vendor/addons/controls/OrbitControls.js") for r in resources)
    assert _severe_console(browser) == []
    assert not browser.find_element(By.ID, "error").is_displayed()


@needs_browser
def test_zero_and_random_buttons_move_the_sliders_within_limits(server, browser):
    _open(browser, f"{server}/viewer")  # no id: the page opens ur5 and says so in the address
    assert browser.current_url == f"{server}/viewer/ur5" and _state(browser)["modelId"] == "ur5"
    browser.find_element(By.ID, "btn-random").click()
    _wait(browser, lambda d: any(abs(v) > 1e-6 for v in d.execute_script(
        "return [...document.querySelectorAll('#sliders input')].map(i => +i.value)")), "random values")
    values = browser.execute_script(
        "return [...document.querySelectorAll('#sliders input')].map(i => [+i.value, +i.min, +i.max])")
    assert all(lo <= v <= hi for v, lo, hi in values)
    browser.find_element(By.ID, "btn-zero").click()
    _wait(browser, lambda d: all(v == 0 for v in d.execute_script(
        "return [...document.querySelectorAll('#sliders input')].map(i => +i.value)")), "zero values")
    _wait(browser, lambda d: _state(d)["fkResponses"] == _state(d)["fkRequests"], "the last FK answer")
    pose = _state(browser)["lastPose"]
    home = httpx.post(f"{server}/models/ur5/fk", json={"q": [0] * 6, "links": [pose["link"]]}).json()
    np.testing.assert_allclose(pose["position"], home["poses"][pose["link"]]["position"], atol=1e-12)


@needs_browser
def test_unknown_model_shows_the_problem_detail(server, browser):
    browser.get(f"{server}/viewer/no_such_robot")
    _wait(browser, lambda d: d.find_element(By.ID, "error").is_displayed(), "the error banner")
    text = browser.find_element(By.ID, "error-text").text
    problem = httpx.get(f"{server}/models/no_such_robot").json()
    assert problem["detail"] in text and "no_such_robot" in text


@needs_browser
def test_dh_editor_builds_shows_and_downloads_a_model(server, browser):
    _open(browser, f"{server}/viewer/ur5")
    browser.find_element(By.CSS_SELECTOR, '.tabs button[data-tab="dh"]').click()
    browser.execute_script("document.querySelectorAll('#dh-table tbody tr').forEach(tr => tr.remove())")
    rows = [  # planar 2R, standard DH, degrees
        {"type": "revolute", "a": "0.5", "alpha": "0", "d": "0", "theta": "0", "lower": "-90", "upper": "90"},
        {"type": "revolute", "a": "0.3", "alpha": "0", "d": "0", "theta": "30", "lower": "", "upper": ""},
    ]
    for row in rows:
        browser.find_element(By.ID, "dh-add").click()
        tr = browser.find_elements(By.CSS_SELECTOR, "#dh-table tbody tr")[-1]
        for field, value in row.items():
            el = tr.find_element(By.CSS_SELECTOR, f'[data-field="{field}"]')
            if field == "type":
                browser.execute_script("arguments[0].value = arguments[1]", el, value)
            else:
                el.clear()
                el.send_keys(value)
    name = browser.find_element(By.ID, "dh-name")
    name.clear()
    name.send_keys("viewer_2r")
    browser.find_element(By.ID, "dh-build").click()
    _wait(browser, lambda d: _state(d)["dhBuilt"] is not None and _state(d)["modelId"] == _state(d)["dhBuilt"]
          and _state(d)["ready"], "the built model in the viewer")
    model_id = _state(browser)["dhBuilt"]
    ARTIFACTS.mkdir(exist_ok=True)
    browser.save_screenshot(str(ARTIFACTS / "viewer_dh_2r.png"))
    assert model_id in browser.find_element(By.ID, "dh-result").text
    assert browser.current_url.endswith(f"/viewer/{model_id}")
    listed = {m["id"]: m for m in httpx.get(f"{server}/models").json()}
    assert listed[model_id]["dof"] == 2
    picker = browser.execute_script("return [...document.querySelectorAll('#model-picker option')].map(o => o.value)")
    assert model_id in picker
    sliders = browser.execute_script(
        "return [...document.querySelectorAll('#sliders input')].map(i => [+i.min, +i.max])")
    assert sliders[0] == pytest.approx([-np.pi / 2, np.pi / 2]) and sliders[1] == pytest.approx([-np.pi, np.pi])

    # at q = 0 the tip of a 2R arm (0.5, 0.3; theta2 = 30 deg) is at (0.5 + 0.3 cos 30, 0.3 sin 30, 0)
    info = httpx.get(f"{server}/models/{model_id}").json()
    fk = httpx.post(f"{server}/models/{model_id}/fk", json={"q": [0, 0], "links": "all"}).json()["poses"]
    expected = [0.5 + 0.3 * np.cos(np.pi / 6), 0.3 * np.sin(np.pi / 6), 0.0]
    tips = [link for link in info["links"] if np.allclose(fk[link]["position"], expected, atol=1e-9)]
    assert tips, "no link of the built model at the closed-form tip position"
    pose = _state(browser)["lastPose"]
    np.testing.assert_allclose(pose["position"], expected, atol=1e-9)

    # download URDF saves exactly GET /models/{id}/urdf
    browser.find_element(By.ID, "dh-download").click()
    target = browser.downloads / f"{model_id}.urdf"
    served = httpx.get(f"{server}/models/{model_id}/urdf").text
    _wait(browser, lambda d: target.exists() and target.read_text() == served, "the downloaded URDF, complete")

    # the editor reloads the table of the shown model; building it again gives the same model
    browser.find_element(By.ID, "dh-edit-current").click()
    assert browser.find_element(By.ID, "dh-angles").get_attribute("value") == info["dh_table"]["angles"]
    assert len(browser.find_elements(By.CSS_SELECTOR, "#dh-table tbody tr")) == 2
    builds = browser.execute_script("return window.viewerState.dhBuilds")
    browser.find_element(By.ID, "dh-build").click()
    _wait(browser, lambda d: _state(d)["dhBuilds"] == builds + 1 and _state(d)["ready"], "the rebuilt model")
    assert _state(browser)["dhBuilt"] == model_id

    # a cell that is neither a number nor a symbol is refused in the page, naming the row and column
    # (symbols such as "abc" give the table's closed form: test_viewer_closed_form.py)
    browser.find_element(By.ID, "dh-add").click()
    tr = browser.find_elements(By.CSS_SELECTOR, "#dh-table tbody tr")[-1]
    a = tr.find_element(By.CSS_SELECTOR, '[data-field="a"]')
    a.clear()
    a.send_keys("1.2.3")
    browser.find_element(By.ID, "dh-build").click()
    _wait(browser, lambda d: d.find_element(By.ID, "error").is_displayed(), "the error banner")
    assert "row 3" in browser.find_element(By.ID, "error-text").text
    assert _severe_console(browser) == []


#: IK target tests: the page's answer is the service's, whose tolerance is 1e-6 (m, rad)
IK_POSITION_TOL = 1e-5
IK_ROTATION_TOL = 1e-5
#: a UR5 configuration off its singularities (wrist_2 != 0, elbow bent)
UR5_Q_KNOWN = [0.3, -1.1, 1.3, -0.6, 0.9, 0.4]
#: a target this far from the UR5's base is out of its reach (about 0.95 m)
UNREACHABLE_OFFSET = [5.0, 0.0, 0.0]


def _ur5_fk(q, link: str = "tool0") -> np.ndarray:
    from kinematics import default_catalogue, fk

    return np.asarray(fk(default_catalogue().get("ur5"), q, links=[link]).poses[0, 0])


def _pose_error(T: np.ndarray, position, quaternion) -> tuple[float, float]:
    from kinematics.spatial import quaternion_to_matrix
    from kinematics.spatial.rotations import rotation_angle

    R = quaternion_to_matrix(quaternion["w"], quaternion["x"], quaternion["y"], quaternion["z"])
    return float(np.linalg.norm(T[:3, 3] - np.asarray(position))), float(rotation_angle(T[:3, :3].T @ R))


def _quaternion(T: np.ndarray) -> dict[str, float]:
    from kinematics.spatial import matrix_to_quaternion

    w, x, y, z = (float(v) for v in matrix_to_quaternion(T[:3, :3]))
    return {"w": w, "x": x, "y": y, "z": z}


def _slider_inputs(driver) -> list[list[float]]:
    return driver.execute_script(
        "return [...document.querySelectorAll('#sliders input')].map(i => [+i.value, +i.step, +i.min, +i.max])")


def _enable_ik(driver) -> None:
    box = driver.find_element(By.ID, "ik-enable")
    assert not box.is_selected()
    box.click()
    _wait(driver, lambda d: _state(d)["ikEnabled"], "the IK target to turn on")


@needs_browser
def test_ik_target_solves_a_reachable_target_and_reports_an_unreachable_one(server, browser):
    _open(browser, f"{server}/viewer/ur5")
    first = _state(browser)["selectedLink"]
    q0 = browser.execute_script("return window.viewerTest.sliderValues()")

    # turning the target on puts it (and the gizmo) on the selected link's pose, and draws it
    before = _canvas_image(browser)
    _enable_ik(browser)
    assert f"target of {first}" in browser.find_element(By.ID, "ik-status").text
    target = browser.execute_script("return window.viewerTest.targetPose()")
    position_error, rotation_error = _pose_error(_ur5_fk(q0, first), target["position"], target["quaternion"])
    assert position_error < 1e-9 and rotation_error < 1e-7
    _wait(browser, lambda d: _changed_fraction(before, _canvas_image(d)) > MIN_CHANGED_FRACTION, "the gizmo drawn")

    # picking another link in the list moves the target onto it
    Select(browser.find_element(By.ID, "link-list")).select_by_value("tool0")
    _wait(browser, lambda d: _state(d)["selectedLink"] == "tool0"
          and "target of tool0" in d.find_element(By.ID, "ik-status").text, "the target on tool0")
    target = browser.execute_script("return window.viewerTest.targetPose()")
    position_error, rotation_error = _pose_error(_ur5_fk(q0), target["position"], target["quaternion"])
    assert position_error < 1e-9 and rotation_error < 1e-7
    assert _state(browser)["ikRequests"] == 0  # turning it on or moving it to a link asks nothing

    # a target at FK of a known configuration: the page's q reaches it (FK in Python)
    T = _ur5_fk(UR5_Q_KNOWN)
    position, quaternion = T[:3, 3].tolist(), _quaternion(T)
    result = browser.execute_script("return window.viewerTest.ikTo(arguments[0], arguments[1])", position, quaternion)
    status = browser.find_element(By.ID, "ik-status").text
    assert status.startswith("IK: solved in ") and "position error" in status and "rotation error" in status, status
    assert result["status"] == status
    last = result["last"]
    assert last["success"] is True and last["link"] == "tool0" and last["mode"] == "pose"
    assert f"solved in {last['iterations']} iterations" in status
    assert last["seed"] == pytest.approx(q0, abs=0)  # seeded with the sliders' values
    np.testing.assert_allclose(last["target"]["position"], position, atol=1e-12)
    q = browser.execute_script("return window.viewerTest.sliderValues()")
    assert q == pytest.approx(result["q"], abs=0) and q == pytest.approx(last["q"], abs=0)
    assert all(np.isfinite(q))
    position_error, rotation_error = _pose_error(_ur5_fk(q), position, quaternion)
    assert position_error < IK_POSITION_TOL and rotation_error < IK_ROTATION_TOL
    # the sliders hold q (thumbs rounded to their step), the arm is drawn at q, the panel says so
    for value, (thumb, step, lo, hi) in zip(q, _slider_inputs(browser)):
        assert abs(thumb - min(max(value, lo), hi)) <= step / 2 + 1e-12
    state = _state(browser)
    assert state["lastQ"] == pytest.approx(q, abs=0)
    assert state["fkResponses"] == state["fkRequests"]
    _wait(browser, lambda d: _panel(d)["pose-link"] == "tool0"
          and np.allclose(_numbers(_panel(d)["pose-position"]), position, atol=10 ** -PANEL_DECIMALS),
          "the pose panel at the target")
    labels = browser.execute_script("return [...document.querySelectorAll('#sliders .value')].map(e => e.textContent)")
    assert [float(t.split()[0]) for t in labels] == pytest.approx(q, abs=10 ** -PANEL_DECIMALS)
    _docs_screenshot(browser, "viewer_ik_solved.png")

    # a target 5 m away: not reachable, the best effort is shown, the sliders stay finite
    far = (np.asarray(position) + UNREACHABLE_OFFSET).tolist()
    result = browser.execute_script("return window.viewerTest.ikTo(arguments[0], arguments[1])", far, quaternion)
    status = browser.find_element(By.ID, "ik-status").text
    assert status.startswith("IK: not reachable — best effort shown (position error"), status
    last = result["last"]
    assert last["success"] is False and last["position_error"] > 3.0
    assert last["seed"] == pytest.approx(q, abs=0)
    q_far = browser.execute_script("return window.viewerTest.sliderValues()")
    assert len(q_far) == 6 and all(np.isfinite(q_far))
    assert all(np.isfinite(v[0]) for v in _slider_inputs(browser))
    # the answer's error is the distance of FK(q) from the target; the target stays put
    position_error, _ = _pose_error(_ur5_fk(q_far), far, quaternion)
    assert position_error == pytest.approx(last["position_error"], rel=1e-6)
    np.testing.assert_allclose(browser.execute_script("return window.viewerTest.targetPose()")["position"], far,
                               atol=1e-12)
    _wait(browser, lambda d: _state(d)["fkResponses"] == _state(d)["fkRequests"], "the last FK answer")
    browser.save_screenshot(str(ARTIFACTS / "viewer_ik_unreachable.png"))

    # position only: any orientation of the target, the position is reached
    Select(browser.find_element(By.ID, "ik-mode")).select_by_value("position")
    browser.execute_script("return window.viewerTest.whenSettled()")  # the mode change re-solves
    upside_down = {"w": 0.0, "x": 1.0, "y": 0.0, "z": 0.0}
    result = browser.execute_script("return window.viewerTest.ikTo(arguments[0], arguments[1])", position, upside_down)
    status = browser.find_element(By.ID, "ik-status").text
    assert status.startswith("IK: solved in ") and "rotation error" not in status, status
    assert result["last"]["mode"] == "position"
    position_error, _ = _pose_error(_ur5_fk(result["q"]), position, upside_down)
    assert position_error < IK_POSITION_TOL

    # the rotate gizmo is drawn instead of the arrows
    before = _canvas_image(browser)
    Select(browser.find_element(By.ID, "ik-gizmo-mode")).select_by_value("rotate")
    _wait(browser, lambda d: _changed_fraction(before, _canvas_image(d)) > MIN_CHANGED_FRACTION,
          "the rotate gizmo drawn instead of the arrows")
    browser.save_screenshot(str(ARTIFACTS / "viewer_ik_rotate.png"))

    # turning it off hides the gizmo and the status; moving a slider works as before
    browser.find_element(By.ID, "ik-enable").click()
    _wait(browser, lambda d: not _state(d)["ikEnabled"], "the IK target to turn off")
    assert browser.find_element(By.ID, "ik-status").text == ""
    resources = browser.execute_script("return performance.getEntriesByType('resource').map(e => e.name)")
    assert all(r.startswith(server + "/") for r in resources), resources
    assert any(r.endswith("/vendor/addons/controls/TransformControls.js") for r in resources)
    assert _severe_console(browser) == []
    assert not browser.find_element(By.ID, "error").is_displayed()


@needs_browser
def test_dragging_the_gizmo_with_the_mouse_moves_the_arm(server, browser):
    from selenium.webdriver.common.actions.action_builder import ActionBuilder

    _open(browser, f"{server}/viewer/ur5")
    # off the zero configuration's singularities, so small moves stay reachable
    for name, value in zip(("shoulder_lift_joint", "elbow_joint", "wrist_2_joint"), (-1.2, 1.0, 0.8)):
        _set_slider(browser, name, value)
    _wait(browser, lambda d: _state(d)["fkResponses"] == _state(d)["fkRequests"]
          and _state(d)["lastQ"][4] == pytest.approx(0.8, abs=1e-2), "the last FK answer")
    q0 = browser.execute_script("return window.viewerTest.sliderValues()")
    _enable_ik(browser)
    link = _state(browser)["selectedLink"]
    start = browser.execute_script("return window.viewerTest.targetPose()")
    np.testing.assert_allclose(start["position"], _ur5_fk(q0, link)[:3, 3], atol=1e-9)
    _frames_drawn(browser)

    # press on the x arrow of the gizmo, drag it to the right in small steps, release
    handle = browser.execute_script("return window.viewerTest.gizmoHandlePoint('X')")
    tip = browser.execute_script("return window.viewerTest.gizmoHandlePoint('X', 1.4)")
    direction = np.array([tip["x"] - handle["x"], tip["y"] - handle["y"]])
    direction /= np.linalg.norm(direction)
    actions = ActionBuilder(browser, duration=20)
    x, y = handle["x"], handle["y"]
    actions.pointer_action.move_to_location(int(round(x)), int(round(y)))
    actions.pointer_action.pointer_down()
    for _ in range(15):
        x, y = x + 4 * direction[0], y + 4 * direction[1]
        actions.pointer_action.move_to_location(int(round(x)), int(round(y)))
        actions.pointer_action.pause(0.03)
    actions.pointer_action.pointer_up()
    started = time.monotonic()
    actions.perform()
    elapsed = time.monotonic() - started
    browser.execute_script("return window.viewerTest.whenSettled()")

    moved = browser.execute_script("return window.viewerTest.targetPose()")
    delta = np.asarray(moved["position"]) - np.asarray(start["position"])
    assert delta[0] > 0.01, f"the drag did not move the target along x: {delta}"
    assert abs(delta[1]) < 1e-9 and abs(delta[2]) < 1e-9, delta  # the x handle moves along x only
    np.testing.assert_allclose([moved["quaternion"][k] for k in "wxyz"],
                               [start["quaternion"][k] for k in "wxyz"], atol=1e-12)
    state = _state(browser)
    assert state["ikResponses"] == state["ikRequests"]
    # asked while dragging (throttled: at most one per 100 ms) and once more at the drag end
    assert 2 <= state["ikRequests"] <= 2 + elapsed / 0.1, (state["ikRequests"], elapsed)
    assert state["ikLast"]["final"] is True  # the last request is the drag end's
    assert not state["ikBusy"]
    status = browser.find_element(By.ID, "ik-status").text
    assert status.startswith("IK: solved in "), status
    q = browser.execute_script("return window.viewerTest.sliderValues()")
    assert q != q0
    position_error, rotation_error = _pose_error(_ur5_fk(q, link), moved["position"], moved["quaternion"])
    assert position_error < IK_POSITION_TOL and rotation_error < IK_ROTATION_TOL
    ARTIFACTS.mkdir(exist_ok=True)
    browser.save_screenshot(str(ARTIFACTS / "viewer_ik_drag.png"))

    # a hand-made slider move afterwards puts the target back on the link
    _set_slider(browser, "wrist_1_joint", 0.5)
    _wait(browser, lambda d: np.allclose(d.execute_script("return window.viewerTest.targetPose()")["position"],
                                         _ur5_fk(d.execute_script("return window.viewerTest.sliderValues()"),
                                                 link)[:3, 3],
                                         atol=1e-9), "the target to follow the link")
    assert _severe_console(browser) == []


# -- without a browser --------------------------------------------------------------------

def test_page_and_static_files_reference_no_external_url(server):
    page = httpx.get(f"{server}/viewer/ur5")
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    csp = page.headers["content-security-policy"]
    assert "default-src 'self'" in csp and "connect-src 'self'" in csp
    for text in (page.text, httpx.get(f"{server}/viewer/static/viewer.js").text,
                 httpx.get(f"{server}/viewer/static/viewer.css").text):
        assert "http://" not in text and "https://" not in text and "//cdn" not in text
    module = httpx.get(f"{server}/viewer/static/vendor/three.module.js")
    assert module.status_code == 200 and "javascript" in module.headers["content-type"]
    assert httpx.get(f"{server}/viewer").status_code == 200
    # the import map in the page points at files the server has
    start = page.text.index('<script type="importmap">') + len('<script type="importmap">')
    imports = json.loads(page.text[start:page.text.index("</script>", start)])["imports"]
    assert httpx.get(server + imports["three"]).status_code == 200
    assert httpx.get(server + imports["three/addons/"] + "controls/OrbitControls.js").status_code == 200
    gizmo = httpx.get(server + imports["three/addons/"] + "controls/TransformControls.js")
    assert gizmo.status_code == 200 and "javascript" in gizmo.headers["content-type"]
    assert "class TransformControls" in gizmo.text
    # it imports only `three`, which the import map resolves to the vendored copy
    assert re.findall(r"^\s*\}?\s*from\s+'([^']+)'", gizmo.text, flags=re.M) == ["three"]


@pytest.mark.parametrize("path", ["../routes/viewer.py", "%2e%2e/%2e%2e/main.py", "nope.js", "vendor"])
def test_static_route_serves_only_viewer_files(server, path):
    r = httpx.get(f"{server}/viewer/static/{path}")
    assert r.status_code == 404
    assert r.headers["content-type"].startswith("application/problem+json")


@pytest.mark.parametrize("path", ["../routes/viewer.py", "../../main.py", "/etc/passwd", "vendor/../../static"])
def test_static_handler_refuses_paths_outside_the_viewer_directory(path):
    from app.errors import ProblemError
    from app.routes.viewer import viewer_static

    with pytest.raises(ProblemError) as info:
        viewer_static(path)
    assert info.value.status == 404


def test_visuals_endpoint_lists_primitives_with_their_origins(server):
    from kinematics import default_catalogue

    model = default_catalogue().get("double_pendulum_simple")
    r = httpx.get(f"{server}/viewer/api/double_pendulum_simple/visuals")
    assert r.status_code == 200
    visuals = r.json()["visuals"]
    assert set(visuals) == set(model.links)
    for link, expected in model.visuals.items():
        got = visuals[link]
        assert [v["kind"] for v in got] == [v.kind for v in expected]
        for g, e in zip(got, expected):
            np.testing.assert_array_equal(g["origin"], e.origin)
            assert g["size"] == list(e.size)
    assert any(v["kind"] == "box" for vs in visuals.values() for v in vs)
    missing = httpx.get(f"{server}/viewer/api/no_such_robot/visuals")
    assert missing.status_code == 404 and "no_such_robot" in missing.json()["detail"]


def test_vendored_threejs_has_its_licence():
    vendor = REPO / "app" / "static" / "viewer" / "vendor"
    assert "MIT" in (vendor / "LICENSE").read_text() or "Permission is hereby granted" in (vendor / "LICENSE").read_text()
    # the version the script records is the one vendored (three.core.js holds REVISION)
    version = re.search(r"three\.js (\d+)\.(\d+)\.\d+", (vendor / "README.md").read_text())
    assert version, "vendor/README.md does not name the three.js version"
    core = (vendor / "three.core.js").read_text(encoding="utf-8")
    assert re.search(r"const REVISION = '(\d+)'", core).group(1) == version.group(2)
    assert os.access(REPO / "scripts" / "vendor_threejs.sh", os.X_OK)
