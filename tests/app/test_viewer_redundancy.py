"""The viewer's self-motion of a 7-joint arm (app/static/viewer/self-motion.js), in a real headless
Chromium (see test_viewer.py): the slider over the parameter, the bar of its in-limit ranges per
branch and the solutions at the slider's value are what the service answers, and moving the slider
moves the arm along its self-motion (the joints change, the pose stays)."""

from __future__ import annotations

import httpx
import numpy as np

from tests.app.test_viewer import (_docs_screenshot, _enable_ik, _open, _set_slider,  # noqa: F401
                                   _severe_console, _state, _wait, browser, needs_browser, server)
from tests.app.test_viewer_ghosts import _js, _settled

try:
    from selenium.webdriver.common.by import By
except ImportError:  # pragma: no cover - needs_browser skips the tests
    pass

LINK = "panda_link8"
PARAMETER = "panda_joint7"
#: the arm before the self-motion (joints 1-7, then the finger): within the limits, q7 inside an
#: in-limit range of the parameter
Q_START = [0.3, -0.5, 0.2, -2.0, 0.4, 1.8, 0.7, 0.02]
#: where the slider is dragged: q7 values passed over, the last one where it rests
SWEEP = np.linspace(0.75, 1.5, 16).tolist()
#: the robot follows its branch through slices of q7 this far apart (SELF_MOTION_TRACK_STEP of config.js)
TRACK_STEP = 0.02
#: on a branch away from its ends a joint moves far less than this between slices (the branches of
#: this target lie about a radian or more apart; the sweep measured 0.06)
MAX_JOINT_STEP = 0.2
#: an IK solution's pose error, and its distance to the parameter value asked for
EXACT = 1e-9
#: the first self-motion request of a fresh service compiles its kernels: minutes on a loaded machine
WARM_UP_TIMEOUT = 600.0


def _pose(server: str, q) -> dict:
    return httpx.post(f"{server}/models/panda/fk", json={"q": list(q), "links": [LINK]}).json()["poses"][LINK]


def _rotation(pose: dict) -> np.ndarray:
    return np.asarray(pose["matrix"])[:3, :3]


def _self_motion(server: str, target: dict, seed, **redundancy) -> dict:
    return httpx.post(f"{server}/models/panda/ik", json={
        "link": LINK, "target": target, "seed": list(seed), "solutions": "all", "limits": "ignore",
        "redundancy": {"parameter": {"joint": PARAMETER}, **redundancy}}, timeout=WARM_UP_TIMEOUT).json()


@needs_browser
def test_the_slider_sweeps_the_panda_along_its_self_motion(server, browser):
    _open(browser, f"{server}/viewer/panda")
    browser.find_element(By.CSS_SELECTOR, f'#link-list option[value="{LINK}"]').click()
    _wait(browser, lambda d: _state(d)["selectedLink"] == LINK, f"{LINK} selected")
    names = _js(browser, "window.viewerState.modelId && window.viewerTest.sliderValues().length")
    assert names == len(Q_START)
    for joint, value in zip([f"panda_joint{i}" for i in range(1, 8)] + ["panda_finger_joint1"], Q_START):
        _set_slider(browser, joint, value)
    _settled(browser)
    q0 = _js(browser, "window.viewerTest.sliderValues()")
    assert np.allclose(q0, Q_START, atol=1e-3)                  # the thumbs snap to their step

    # the same request as the page's first one, straight to the service (it also compiles the kernels)
    start = _pose(server, q0)
    target = {"position": start["position"], "quaternion": start["quaternion"]}
    api = _self_motion(server, target, q0, intervals=True, values=[q0[6]])
    assert api["intervals"], "the start's q7 lies in an in-limit range"

    _enable_ik(browser)
    _wait(browser, lambda d: (_js(d, "window.viewerState.selfMotion") or {}).get("count") is not None
          and not _state(d)["selfMotionBusy"] and not _state(d)["ghostBusy"], "the self-motion of the target")
    _settled(browser)
    sm = _js(browser, "window.viewerState.selfMotion")
    info = httpx.get(f"{server}/models/panda").json()
    limits = next(j["limits"] for j in info["joints"] if j["name"] == PARAMETER)
    assert sm["joint"] == PARAMETER and (sm["lower"], sm["upper"]) == (limits["lower"], limits["upper"])
    assert sm["value"] == q0[6]
    assert np.allclose(_js(browser, "window.viewerTest.targetPose()")["position"], target["position"], atol=1e-12)

    # the bar: the service's in-limit ranges, one row for their union and one per branch
    assert len(sm["intervals"]) == len(api["intervals"])
    for page, ref in zip(sm["intervals"], api["intervals"]):
        assert abs(page["from"] - ref["from"]) < EXACT and abs(page["to"] - ref["to"]) < EXACT
        assert [p["branch"] for p in page["branches"]] == [p["branch"] for p in ref["branches"]]
    bar = _js(browser, "window.viewerTest.selfMotionBar()")
    branches = sorted({p["branch"] for r in api["intervals"] for p in r["branches"]})
    assert [row["label"] for row in bar] == ["any"] + [f"b{b}" for b in branches]
    # (the page's own request and this one may find the ends a rounding apart: within EXACT, as above)
    want = [sorted((p["from"], p["to"]) for r in api["intervals"] for p in r["branches"] if p["branch"] == b)
            for b in branches]
    got = [[tuple(p) for p in row["pieces"]] for row in bar[1:]]
    assert [len(row) for row in got] == [len(row) for row in want]
    assert np.allclose(np.array([p for row in got for p in row]), np.array([p for row in want for p in row]),
                       rtol=0, atol=EXACT)
    assert np.allclose(np.array([tuple(p) for p in bar[0]["pieces"]]),
                       np.array([(r["from"], r["to"]) for r in api["intervals"]]), rtol=0, atol=EXACT)
    assert not browser.find_element(By.ID, "sm-panel").get_attribute("hidden")

    # at the start's own q7 the robot stays where it is, on its branch; the other branches are ghosts
    assert np.allclose(_js(browser, "window.viewerTest.sliderValues()"), q0, atol=EXACT)
    ghosts = _js(browser, "window.viewerState.ghosts")
    assert ghosts["count"] == api["count"] == len(api["solutions"]) > 1
    assert ghosts["parameter"] == {"joint": PARAMETER, "value": q0[6]}
    assert ghosts["chosen"] == sm["chosen"] >= 0

    # a drag of the slider: one request, for the value it rests on (debounced, one in flight)
    before = _state(browser)["selfMotionRequests"]
    browser.execute_script(
        """const input = document.getElementById('sm-slider');
           for (const v of arguments[0]) {
             input.value = String(v);
             input.dispatchEvent(new Event('input', {bubbles: true}));
           }""",
        SWEEP)
    value = float(_js(browser, "Number(document.getElementById('sm-slider').value)"))
    assert abs(value - SWEEP[-1]) < 1e-2
    _settled(browser)
    assert _state(browser)["selfMotionRequests"] == before + 1
    sm = _js(browser, "window.viewerState.selfMotion")
    assert sm["value"] == value

    # the robot moved along its self-motion: q7 is the slider's value, the other joints changed, the
    # pose of the link stayed (FK by the service of the joint values the page shows, and as drawn)
    q1 = _js(browser, "window.viewerTest.sliderValues()")
    assert abs(q1[6] - value) < EXACT
    assert np.abs(np.subtract(q1[:6], q0[:6])).max() > 0.01
    assert np.allclose(sm["q"], q1, atol=0)
    moved = _pose(server, q1)
    assert np.linalg.norm(np.subtract(moved["position"], start["position"])) < EXACT
    assert np.abs(_rotation(moved) - _rotation(start)).max() < EXACT
    assert np.allclose(_state(browser)["lastQ"], q1, atol=0)   # the FK drawn is of that configuration
    assert np.linalg.norm(np.subtract(_state(browser)["lastPose"]["position"], start["position"])) < EXACT

    # the robot followed its branch: through the slices between its q7 and the slider's, each
    # solution nearest the one before (done again here on the service's answer), no joint jumping
    values = sm["track"]["values"]
    assert len(values) == int(np.ceil(abs(value - q0[6]) / TRACK_STEP)) and values[-1] == value
    followed = _self_motion(server, target, q0, values=values)["solutions"]
    q = np.asarray(q0)
    for v in values:
        at_v = [s["q"] for s in followed if abs(s["parameter"] - v) < 1e-12]
        q = np.asarray(min(at_v, key=lambda s: np.linalg.norm(np.subtract(s, q))))
    assert np.allclose(q, q1, atol=EXACT)
    assert sm["track"]["maxStep"] < MAX_JOINT_STEP

    # the ghosts are every solution at the new value, as the service lists them
    ref = _self_motion(server, target, q0, values=[value])
    ghosts = _js(browser, "window.viewerState.ghosts")
    assert ghosts["count"] == ref["count"] and ghosts["parameter"]["value"] == value
    assert np.allclose(sorted(s["q"] for s in ghosts["solutions"]), sorted(s["q"] for s in ref["solutions"]),
                       atol=1e-12)
    assert any(np.allclose(s["q"], q1, atol=0) for s in ghosts["solutions"])
    assert f"at {PARAMETER} = {value:.3f}" in browser.find_element(By.ID, "ghost-status").text

    browser.execute_script("document.getElementById('sm-panel').scrollIntoView({block: 'center'})")
    _docs_screenshot(browser, "viewer_redundancy.png")
    assert _severe_console(browser) == []
