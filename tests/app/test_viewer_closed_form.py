"""The viewer's "Closed form" tab (POST /models/{id}/symbolic typeset by the vendored KaTeX) and the
DH editor's symbols (POST /symbolic/dh), in a real headless Chromium (see test_viewer.py); and,
without a browser, that the viewer's files load nothing from outside the service."""

from __future__ import annotations

import re

import httpx
import pytest

from tests.app.test_viewer import (ARTIFACTS, PAGE_TIMEOUT, _open, _severe_console, _state, _wait, browser,  # noqa: F401
                                   needs_browser, server)
from tests.paths import REPO

VIEWER_DIR = REPO / "app" / "static" / "viewer"
KATEX_DIR = VIEWER_DIR / "vendor" / "katex"
#: hosts of public CDNs: none may appear anywhere in the viewer's files
CDN_HOSTS = ("cdn.", "jsdelivr", "unpkg", "cdnjs", "googleapis", "gstatic", "esm.sh", "skypack")

try:
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select
except ImportError:  # pragma: no cover
    By = Select = None


def _closed_tab(driver):
    driver.find_element(By.CSS_SELECTOR, '.tabs button[data-tab="closed"]').click()


def _derive(driver, tip: str | None = None, factors: bool = False, jacobian: bool = False) -> dict:
    if tip is not None:
        Select(driver.find_element(By.ID, "cf-tip")).select_by_value(tip)
    for box, on in (("cf-factors", factors), ("cf-jacobian", jacobian)):
        el = driver.find_element(By.ID, box)
        if el.is_selected() != on:
            el.click()
    before = _state(driver)["cfResponses"]
    driver.find_element(By.ID, "cf-derive").click()
    _wait(driver, lambda d: _state(d)["cfResponses"] > before, "the closed form's answer")
    return _state(driver)["closedForm"]


@needs_browser
def test_closed_form_panel_typesets_the_2r_arm(server, browser):
    _open(browser, f"{server}/viewer/planar_2r")
    _closed_tab(browser)
    assert browser.find_element(By.ID, "cf-tip").get_attribute("value") == "tool"  # the leaf by default
    cf = _derive(browser, factors=True, jacobian=True)
    assert cf["ok"], cf
    katex = browser.find_elements(By.CSS_SELECTOR, "#cf-output .katex")
    assert len(katex) == cf["katex"] >= 1 + 2 + 2  # T, A_1, A_2, two Jacobians (and base/tool when not identity)
    assert browser.find_elements(By.CSS_SELECTOR, "#cf-output .katex-html")  # typeset, not the raw source
    # KaTeX's MathML copy carries the textbooks' notation: c_12 = cos(q1 + q2)
    mathml = browser.execute_script("return document.querySelector('#cf-output .katex-mathml').textContent")
    assert "c" in mathml and "12" in mathml
    body = httpx.post(f"{server}/models/planar_2r/symbolic", json={"tip": "tool", "format": "latex"}).json()
    assert "c_{12}" in body["T"]
    fonts = browser.execute_script(
        "return performance.getEntriesByType('resource').map(e => e.name).filter(n => n.includes('KaTeX_'))")
    assert fonts and all(f.startswith(server) for f in fonts)  # fonts from the service itself
    ARTIFACTS.mkdir(exist_ok=True)
    browser.save_screenshot(str(ARTIFACTS / "viewer_closed_form_2r.png"))
    assert not _severe_console(browser)


@needs_browser
def test_closed_form_panel_on_ur5_and_a_clear_message_on_a_problem(server, browser):
    _open(browser, f"{server}/viewer/ur5")
    _closed_tab(browser)
    cf = _derive(browser, tip="tool0")
    assert cf["ok"] and cf["katex"] == 1, cf
    assert "ur5: world to tool0" in browser.find_element(By.ID, "cf-status").text
    ARTIFACTS.mkdir(exist_ok=True)
    browser.save_screenshot(str(ARTIFACTS / "viewer_closed_form_ur5.png"))
    # the root link has no chain: the service answers 422, the panel says so (and drops the old T)
    cf = _derive(browser, tip="world")
    status = browser.find_element(By.ID, "cf-status")
    assert not cf["ok"] and cf["httpStatus"] == 422, cf
    assert "422 invalid-symbolic-request" in status.text and "no moving joint" in status.text
    assert "warn" in status.get_attribute("class")
    assert not browser.find_elements(By.CSS_SELECTOR, "#cf-output .katex")
    assert all("status of 422" in m for m in _severe_console(browser))  # only the refused request


@needs_browser
def test_closed_form_panel_reports_the_time_limit(server, browser):
    """Over the derivation's own time limit (the request's timeout, the client's choice): 422
    time-budget-exceeded, said with its hint."""
    _open(browser, f"{server}/viewer/panda")
    _closed_tab(browser)
    browser.execute_script("""
        const orig = window.fetch;
        window.fetch = (url, init) => {
          if (String(url).endsWith('/symbolic') && init && init.body) {
            const body = JSON.parse(init.body); body.timeout = 0.1; init = {...init, body: JSON.stringify(body)};
          }
          return orig(url, init);
        };""")
    cf = _derive(browser, tip="panda_hand_tcp", jacobian=True)
    assert not cf["ok"] and cf["httpStatus"] == 422, cf
    text = browser.find_element(By.ID, "cf-status").text
    assert "time-budget-exceeded" in text and "untick simplify" in text


@needs_browser
def test_dh_editor_with_symbols_shows_their_closed_form(server, browser):
    _open(browser, f"{server}/viewer/ur5")
    browser.find_element(By.CSS_SELECTOR, '.tabs button[data-tab="dh"]').click()
    browser.execute_script("document.querySelectorAll('#dh-table tbody tr').forEach(tr => tr.remove())")
    rows = [  # a 2R arm with symbolic link lengths, standard DH, degrees
        {"a": "a1", "alpha": "0", "d": "0", "theta": "0"},
        {"a": "a2", "alpha": "0", "d": "d2", "theta": "0"},
    ]
    for row in rows:
        browser.find_element(By.ID, "dh-add").click()
        tr = browser.find_elements(By.CSS_SELECTOR, "#dh-table tbody tr")[-1]
        for field, value in row.items():
            el = tr.find_element(By.CSS_SELECTOR, f'[data-field="{field}"]')
            el.clear()
            el.send_keys(value)
    models_before = len(httpx.get(f"{server}/models").json())
    before = _state(browser)["cfResponses"]
    browser.find_element(By.ID, "dh-build").click()  # Build with symbols: a closed form, no model
    _wait(browser, lambda d: _state(d)["cfResponses"] > before, "the DH table's closed form")
    dh = _state(browser)["dhClosed"]
    assert dh["ok"], dh
    assert sorted(dh["parameters"]) == ["a1", "a2", "d2"]
    assert "a_{1}" in dh["T"] and "a_{2}" in dh["T"]
    assert dh["katex"] >= 3  # T, A_1, A_2
    assert "symbols" in browser.find_element(By.ID, "dh-result").text
    mathml = browser.execute_script(
        "return document.querySelector('#dh-closed-form .katex-mathml').textContent")
    assert "a" in mathml and "1" in mathml
    assert len(httpx.get(f"{server}/models").json()) == models_before
    ARTIFACTS.mkdir(exist_ok=True)
    browser.save_screenshot(str(ARTIFACTS / "viewer_dh_symbolic.png"))
    # a bad expression: the service's message, under the editor
    tr = browser.find_elements(By.CSS_SELECTOR, "#dh-table tbody tr")[0]
    cell = tr.find_element(By.CSS_SELECTOR, '[data-field="a"]')
    cell.clear()
    cell.send_keys("cos(x)")
    before = _state(browser)["cfResponses"]
    browser.find_element(By.ID, "dh-closed").click()
    _wait(browser, lambda d: _state(d)["cfResponses"] > before, "the refused table")
    dh = _state(browser)["dhClosed"]
    assert not dh["ok"] and "422" in dh["status"] and "joints[0].a" in dh["status"]
    # numbers only: Build still builds a model
    cell.clear()
    cell.send_keys("0.4")
    for field in ("a", "d"):
        c = browser.find_elements(By.CSS_SELECTOR, "#dh-table tbody tr")[1].find_element(
            By.CSS_SELECTOR, f'[data-field="{field}"]')
        c.clear()
        c.send_keys("0.3" if field == "a" else "0")
    builds = _state(browser)["dhBuilds"]
    browser.find_element(By.ID, "dh-build").click()
    _wait(browser, lambda d: _state(d)["dhBuilds"] > builds and _state(d)["ready"]
          and _state(d)["modelId"] == _state(d)["dhBuilt"], "the numeric table built as a model")
    assert all("status of 422" in m for m in _severe_console(browser))  # only the refused table


# -- without a browser --------------------------------------------------------------------

def _in_comment(line: str, url: str) -> bool:
    """Whether ``url`` on this line of JavaScript stands in a comment (``//``, or a ``*`` block line)."""
    before = line[:line.index(url)]
    return line.lstrip().startswith(("*", "/*", "//")) or "// " in before


def test_no_cdn_reference_in_the_viewers_files(server):
    """Our own files name no http(s) URL at all; the vendored ones load nothing from outside: no
    import, stylesheet, font or script URL with a scheme, and no CDN host anywhere (what remains
    are comments and XML namespace names such as http://www.w3.org/2000/svg)."""
    files = [p for p in VIEWER_DIR.rglob("*") if p.is_file() and p.suffix in (".js", ".css", ".html")]
    assert KATEX_DIR / "katex.min.js" in files and KATEX_DIR / "katex.min.css" in files
    for path in files:
        text = path.read_text(encoding="utf-8")
        rel = path.relative_to(VIEWER_DIR)
        if "vendor" not in rel.parts:
            assert not re.search(r"https?://", text), rel
        for host in CDN_HOSTS:
            assert host not in text.lower(), (rel, host)
        assert not re.search(r"""\bfrom\s*["'](https?:)?//""", text), rel  # ES module imports
        assert not re.search(r"""\bimport\s*\(\s*["'](https?:)?//""", text), rel
        assert not re.search(r"""url\(\s*["']?(https?:)?//""", text), rel  # CSS url(...)
        assert not re.search(r"""@import\s+["']?(https?:)?//""", text), rel
        assert not re.search(r"""\b(src|href)\s*=\s*["'](https?:)?//""", text), rel
        for url in re.findall(r"""https?://[^\s"'`)]+""", text):
            if path.suffix == ".js" and "vendor" in rel.parts and url.startswith("http://www.w3.org/"):
                continue  # namespace names (SVG, MathML, XHTML) are not fetched
            if "vendor" in rel.parts and path.name.startswith("three"):
                continue  # three.js's comments cite papers and issues
            if "addons" in rel.parts and all(_in_comment(line, url) for line in text.splitlines() if url in line):
                continue  # so do its loaders' comments (format specifications, bug reports)
            raise AssertionError(f"{rel}: {url}")
    page = httpx.get(f"{server}/viewer/ur5").text
    assert "/viewer/static/vendor/katex/katex.min.js" in page and "/viewer/static/vendor/katex/katex.min.css" in page
    assert not re.search(r"https?://", page)


def test_vendored_katex_is_served_with_its_fonts_and_licence(server):
    css = httpx.get(f"{server}/viewer/static/vendor/katex/katex.min.css")
    assert css.status_code == 200 and css.headers["content-type"].startswith("text/css")
    js = httpx.get(f"{server}/viewer/static/vendor/katex/katex.min.js")
    assert js.status_code == 200 and "javascript" in js.headers["content-type"]
    woff2 = sorted(set(re.findall(r"fonts/(KaTeX_[\w-]+\.woff2)", css.text)))
    assert woff2
    for name in woff2:  # every woff2 font the stylesheet names is here
        r = httpx.get(f"{server}/viewer/static/vendor/katex/fonts/{name}")
        assert r.status_code == 200 and r.headers["content-type"] == "font/woff2", name
    licence = (KATEX_DIR / "LICENSE").read_text()
    assert "MIT" in licence and "Khan Academy" in licence
    version = re.search(r"KaTeX (\d+\.\d+\.\d+)", (KATEX_DIR / "README.md").read_text()).group(1)
    assert f'version:"{version}"' in js.text.replace(" ", "") or version in js.text
    assert (REPO / "scripts" / "vendor_katex.sh").stat().st_mode & 0o111
