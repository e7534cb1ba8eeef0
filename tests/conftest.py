"""Shared fixtures. Fixture URDFs live in tests/fixtures/."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from tests.paths import FIXTURES  # noqa: F401 - tests import it from here too

# the tests' services load the compiled kernels before they answer (app/warm.py): no warm-up thread runs beside
# a test; tests/app/test_warm_up.py checks the default, in the background
os.environ.setdefault("KIN_WARM_UP", "before_serving")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def catalogue():
    from kinematics import default_catalogue

    return default_catalogue()


@pytest.fixture(scope="session")
def ur5(catalogue):
    """The UR5 of the catalogue: the arm most tests compute with."""
    return catalogue.get("ur5")


# ---------------------------------------------------------------------- REST API (app/)
@pytest.fixture
def api_data_dir(tmp_path) -> Path:
    """An empty data directory for one test's service (shared by every client made from it)."""
    d = tmp_path / "data"
    d.mkdir()
    return d


@pytest.fixture
def get_with_a_bug(api_data_dir):
    """``get(path, headers=None)`` on a service whose registry raises a RuntimeError ("simulated
    bug"): a real bug, as the 500 handler meets it."""
    from fastapi.testclient import TestClient

    from app.main import create_app
    from app.settings import Settings

    def get(path: str, headers: dict | None = None):
        app = create_app(Settings(data_dir=api_data_dir))
        with TestClient(app, raise_server_exceptions=False) as c:
            def broken(model_id):
                raise RuntimeError("simulated bug")

            app.state.registry.get = broken
            return c.get(path, headers=headers)

    return get


@pytest.fixture
def make_client(api_data_dir):
    """Factory: ``make_client(**settings)`` -> a started TestClient on ``api_data_dir``.

    Two clients from one test share the data directory: two replicas of the service.
    """
    from fastapi.testclient import TestClient

    from app.main import create_app
    from app.settings import Settings

    opened = []

    def make(**overrides):
        overrides.setdefault("data_dir", api_data_dir)
        client = TestClient(create_app(Settings(**overrides)))
        client.__enter__()
        opened.append(client)
        return client

    yield make
    for client in reversed(opened):
        client.__exit__(None, None, None)


@pytest.fixture
def api_client(make_client):
    """A TestClient of the service with default settings and an empty data directory."""
    return make_client()


# ---------------------------------------------------------------------- nothing outlives the tests' servers
def _started_by_test_servers(root: str) -> list[tuple[int, str]]:
    """``(pid, command)`` of the processes (not this one nor its children) whose ``KIN_DATA_DIR`` lies
    under ``root``: servers a test started (``tests.live``, ``python -m app``) and what they started."""
    import os

    mine = {os.getpid()}
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit() or int(entry) in mine:
            continue
        try:
            with open(f"/proc/{entry}/environ", "rb") as f:
                env = f.read().split(b"\0")
            with open(f"/proc/{entry}/stat") as f:
                ppid = int(f.read().rsplit(")", 1)[1].split()[1])
            with open(f"/proc/{entry}/cmdline", "rb") as f:
                cmd = f.read().replace(b"\0", b" ").decode(errors="replace").strip()
        except (OSError, ValueError, IndexError):
            continue
        data_dir = next((v[len(b"KIN_DATA_DIR="):] for v in env if v.startswith(b"KIN_DATA_DIR=")), None)
        if ppid not in mine and data_dir is not None and data_dir.decode(errors="replace").startswith(root):
            found.append((int(entry), cmd))
    return found


@pytest.fixture(scope="session", autouse=True)
def no_process_outlives_its_server(tmp_path_factory):
    """After the session, nothing the tests' live servers started is still running (their decoder
    processes, multiprocessing's resource tracker, ...): waits for them to end (a condition, with a
    timeout), then kills any left and fails naming them."""
    import os
    import signal
    import time

    yield
    if not os.path.isdir("/proc"):
        return
    root = str(tmp_path_factory.getbasetemp())
    deadline = time.monotonic() + 30.0
    left = _started_by_test_servers(root)
    while left and time.monotonic() < deadline:
        time.sleep(0.1)
        left = _started_by_test_servers(root)
    for pid, _ in left:
        try:
            os.kill(pid, signal.SIGKILL)
        except OSError:
            pass
    assert not left, f"processes started by the tests' servers outlived them: {left}"
