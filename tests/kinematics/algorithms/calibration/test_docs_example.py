"""The Python example of docs/calibration.md runs and prints what the page says."""

from __future__ import annotations

import re

from tests.paths import REPO


def test_the_docs_example_runs(tmp_path, monkeypatch, capsys):
    text = (REPO / "docs" / "calibration.md").read_text()
    code = re.findall(r"```python\n(.*?)```", text, re.S)[0]
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "docs/calibration.md", "exec"), {})
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("27 ") and out[-1] == "True"
    assert (tmp_path / "ur5_calibrated.urdf").read_text().lstrip().startswith("<?xml")
