"""``kinematics serve`` (added to the library's command line by the service's entry point) and
``python -m app``: both run uvicorn serving ``app.main:app`` in the process, with the
graceful-shutdown timeout of ``KIN_SHUTDOWN_TIMEOUT`` (tests/app/test_shutdown.py runs it for real)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from app import cli as app_cli
from kinematics.cli import main


@pytest.fixture
def execs(monkeypatch):
    calls = []
    monkeypatch.setattr(app_cli, "run_uvicorn", lambda **kw: calls.append(kw) or 0)
    monkeypatch.delenv("KIN_DATA_DIR", raising=False)
    monkeypatch.setenv("KIN_SHUTDOWN_TIMEOUT", "12.5")
    return calls


@pytest.mark.parametrize("entry", ["kinematics serve", "python -m app"])
def test_serve_runs_uvicorn(entry, execs, capsys):
    args = ["--host", "0.0.0.0", "--port", "9123", "--workers", "3", "--data-dir", "/tmp/kin-x"]
    code = main(["serve", *args]) if entry == "kinematics serve" else app_cli.main(args)
    assert code == 0
    call, = execs
    assert call == {"host": "0.0.0.0", "port": 9123, "workers": 3, "shutdown_timeout": 12.5}
    assert os.environ["KIN_DATA_DIR"] == "/tmp/kin-x"


@pytest.mark.parametrize("args, message", [(["--port", "70000"], "not a port number"), (["--workers", "0"], "at least 1")])
def test_serve_refuses_bad_options(args, message, execs, capsys):
    assert main(["serve", *args]) == 2
    assert app_cli.main(args) == 2
    assert not execs
    assert message in capsys.readouterr().err


def test_the_library_command_line_lists_serve_from_the_entry_point():
    out = subprocess.run([sys.executable, "-m", "kinematics", "--help"], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and "serve" in out.stdout
    helped = subprocess.run([sys.executable, "-m", "app", "--help"], capture_output=True, text=True, timeout=60)
    assert helped.returncode == 0 and "--workers" in helped.stdout
