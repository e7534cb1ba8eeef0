"""The documentation site builds offline with ``mkdocs build --strict`` (a broken link, a missing
anchor, an example file that is not there or an API name that does not resolve fails it), and
it loads nothing from the internet.

``make test`` installs the ``docs`` extra, so this runs there and in CI; it is skipped only where
mkdocs is not installed.
"""

from __future__ import annotations

import re
import subprocess
import sys

import pytest
from tests.paths import REPO

pytest.importorskip("mkdocs", reason="the docs extra (pip install -e '.[docs]')")
pytest.importorskip("material", reason="the docs extra (mkdocs-material)")
pytest.importorskip("mkdocstrings_handlers.python", reason="the docs extra (mkdocstrings[python])")

#: what a page may not load: fonts, scripts or styles from another host
EXTERNAL = re.compile(r"""<(?:link|script)[^>]+(?:href|src)=["']https?://""", re.IGNORECASE)


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    out = tmp_path_factory.mktemp("site")
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(REPO / "mkdocs.yml"),
                           "-d", str(out)], cwd=REPO, capture_output=True, text=True, timeout=600,
                          env={"NO_MKDOCS_2_WARNING": "1", "PATH": "/usr/bin:/bin", "HOME": str(out)})
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out


def test_the_site_builds_strict_and_offline(site):
    pages = list(site.rglob("*.html"))
    assert (site / "index.html").is_file() and len(pages) > 20
    for page in pages:
        html = page.read_text(errors="replace")
        assert not EXTERNAL.search(html), f"{page.relative_to(site)} loads from another host"
        assert "fonts.googleapis" not in html, page


def test_the_api_reference_is_generated_from_the_docstrings(site):
    api = (site / "reference" / "api.html").read_text()
    for name in ("kinematics.usecases.fk.fk", "kinematics.usecases.jacobian.jacobian", "kinematics.usecases.ik.ik",
                 "kinematics.api.load_model"):
        assert f'id="{name}"' in api, name
    assert "Poses <code>T_world_link</code>" in api  # the docstring of fk, roles and literals as Markdown
    package = (site / "reference" / "kinematics.html").read_text()
    assert 'id="kinematics.compile_model"' in package and 'id="kinematics.RobotModel"' in package  # the names of __all__
    assert "<code>" in package and "&gt;&gt;&gt;" in package and "::" not in re.sub(r"<[^>]+>", "", package)
    client = (site / "reference" / "client.html").read_text()
    assert 'id="kinematics.client.Client"' in client


def test_the_examples_shown_are_the_example_files(site):
    page = (site / "operations" / "fk.html").read_text()
    assert "01_ur5_fk_jacobian.py" in page
    assert "kinematics.fk" in re.sub(r"<[^>]+>", "", page)  # the script's code, included at build time
    assert "--8&lt;--" not in page and "--8<--" not in page
