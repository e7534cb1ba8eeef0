"""The viewer draws catalogue robots with their real meshes and paints the links in self-collision
red as the joints move, in a real headless Chromium (see test_viewer.py)."""

from __future__ import annotations

import httpx
import pytest

from tests.app.test_viewer import (ARTIFACTS, _canvas_image, _frames_drawn, _open, _set_slider, _severe_console,  # noqa: F401
                                   _state, _wait, browser, needs_browser)
from tests.live import LiveServer

#: the viewer's colour of a link in self-collision (meshes.js COLLIDING_COLOR)
COLLIDING = 0xE0202A
#: the UR5 with its elbow shut: the first wrist link inside the upper arm
UR5_JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
              "wrist_3_joint"]
FOLDED_Q = [0.2, -1.4, 2.87, -2.87, -1.37, 0.4]
FOLDED = dict(zip(UR5_JOINTS, FOLDED_Q))


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """A service whose allowed-collision matrices sample few configurations (quick to compute)."""
    tmp = tmp_path_factory.mktemp("viewer-meshes")
    with LiveServer(tmp / "data", tmp / "uvicorn.log", env={"KIN_COLLISION_SAMPLES": "500"}) as live:
        yield live.url


def _near(q, expected, tol: float = 1e-2) -> bool:
    return q is not None and len(q) == len(expected) and all(abs(a - b) < tol for a, b in zip(q, expected))


def _colours(driver, link: str) -> list[int]:
    return driver.execute_script("return window.viewerDebug.linkColours(arguments[0])", link)


@needs_browser
@pytest.mark.parametrize("model_id", ["ur5", "panda"])
def test_catalogue_models_are_drawn_with_their_meshes(server, browser, model_id):
    _open(browser, f"{server}/viewer/{model_id}")
    meshes = _wait(browser, lambda d: (lambda m: m if m["expected"] and m["loaded"] + m["failed"] == m["expected"]
                                       else None)(_state(d)["meshes"]), "every mesh loaded or failed")
    assert meshes["failed"] == 0 and meshes["loaded"] > 0, meshes["errors"]
    state = _wait(browser, lambda d: (lambda c: c if c["responses"] >= 1 else None)(_state(d)["collision"]),
                  "the first self-collision answer")
    # the page shows what the service answers for the configuration drawn: both open on a free pose
    # (the Panda's q = 0 clamped into its limits touches, so it opens elsewhere: app/static/viewer/defaults.js)
    answer = httpx.post(f"{server}/models/{model_id}/collision", json={"q": state["q"]}).json()
    assert state["pairs"] == answer["pairs"]
    status = browser.find_element("id", "collision-status").text
    assert answer["pairs"] == [] and status == "self-collision: none"
    assert _severe_console(browser) == []


@needs_browser
def test_a_colliding_configuration_turns_its_links_red(server, browser):
    _open(browser, f"{server}/viewer/ur5")
    _wait(browser, lambda d: (lambda m: m["expected"] and m["loaded"] == m["expected"])(_state(d)["meshes"]),
          "the meshes loaded")
    _wait(browser, lambda d: _state(d)["collision"]["responses"] >= 1, "the first self-collision answer")
    assert COLLIDING not in _colours(browser, "upper_arm_link")
    for joint, value in FOLDED.items():
        _set_slider(browser, joint, value)
    state = _wait(browser, lambda d: (lambda c: c if c["links"] and _near(c["q"], FOLDED_Q) else None)(
        _state(d)["collision"]), "the folded arm's collision answer")
    assert "upper_arm_link" in state["links"] and "base_link" not in state["links"]
    answer = httpx.post(f"{server}/models/ur5/collision", json={"q": state["q"]}).json()
    assert state["pairs"] == answer["pairs"]  # the page shows the service's answer for the q drawn
    for link in state["links"]:
        colours = _colours(browser, link)
        assert colours and all(c == COLLIDING for c in colours), (link, colours)
    assert COLLIDING not in _colours(browser, "base_link")
    status = browser.find_element("id", "collision-status").text
    assert status.startswith("self-collision: links ") and "upper_arm_link" in status
    browser.find_element("id", "btn-fit").click()
    _frames_drawn(browser)
    ARTIFACTS.mkdir(exist_ok=True)
    _canvas_image(browser).save(ARTIFACTS / "viewer_meshes.png")
    browser.save_screenshot(str(ARTIFACTS / "viewer_meshes_page.png"))  # with the status line: docs/viewer_meshes.png
    # back to a free configuration: the red goes
    for joint in FOLDED:
        _set_slider(browser, joint, 0.0)
    _wait(browser, lambda d: (lambda c: not c["links"] and _near(c["q"], [0.0] * 6))(_state(d)["collision"]),
          "the stretched arm's collision answer")
    assert COLLIDING not in _colours(browser, "upper_arm_link")
    assert _severe_console(browser) == []


@needs_browser
def test_a_plain_upload_is_a_stick_figure(server, browser, catalogue):
    """The UR5's URDF uploaded as a plain file names meshes the service never reads: no mesh is
    fetched, the page says they are not drawn, and the skeleton is shown."""
    r = httpx.post(f"{server}/models", content=catalogue.get("ur5").urdf.encode(),
                   headers={"Content-Type": "application/xml"})
    mid = r.json()["id"]
    _open(browser, f"{server}/viewer/{mid}")
    assert _state(browser)["meshes"] == {"expected": 0, "loaded": 0, "failed": 0, "errors": []}
    assert "mesh visual(s) not drawn" in browser.find_element("id", "model-warnings").text
    _wait(browser, lambda d: _state(d)["collision"]["responses"] >= 1, "the first self-collision answer")
    assert _severe_console(browser) == []


LOADERS = ["STLLoader.js", "ColladaLoader.js", "OBJLoader.js"]


def test_mesh_loaders_are_vendored_with_what_they_import():
    """The loaders and every file they import are in vendor/addons/ (re-vendored by the script),
    importing only `three` (the import map's) and each other by relative paths."""
    import re

    from tests.paths import REPO

    addons = REPO / "app" / "static" / "viewer" / "vendor" / "addons"
    script = (REPO / "scripts" / "vendor_threejs.sh").read_text()
    todo, seen = [addons / "loaders" / name for name in LOADERS], set()
    while todo:
        path = todo.pop()
        if path in seen:
            continue
        seen.add(path)
        assert path.is_file(), path
        assert path.name in script, f"scripts/vendor_threejs.sh does not copy {path.name}"
        for spec in re.findall(r"""^import[^;]*?from\s+['"]([^'"]+)['"]""", path.read_text(), re.M | re.S):
            if spec != "three":
                assert spec.startswith("."), (path.name, spec)
                todo.append((path.parent / spec).resolve())
    assert len(seen) >= 6  # the three loaders, Collada's parser and composer, the TGA loader
