"""A real ``uvicorn app.main:app`` process on a loopback port, for the tests that need one.

Used by the concurrency, persistence, server and viewer tests. The server runs in its
own session (process group), so :meth:`LiveServer.kill` reaches every worker process it
started, and only those.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
from tests.paths import REPO

#: how long a server may take to answer /health after start (imports Pinocchio, scans data)
STARTUP_TIMEOUT = 90.0
#: what uvicorn logs once a worker's start-up (the app's lifespan: warm-up, registry) is done
READY_LINE = b"Application startup complete."


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class LiveServer:
    """``uvicorn app.main:app`` on 127.0.0.1 with ``KIN_DATA_DIR=data_dir`` (+ ``env``)."""

    def __init__(self, data_dir: Path, log_path: Path, *, workers: int = 1, env: dict[str, str] | None = None,
                 serve: bool = False):
        self.serve = serve  # True: `python -m app` (the product's command), else `python -m uvicorn`
        self.data_dir = Path(data_dir)
        self.log_path = Path(log_path)
        self.workers = workers
        self.extra_env = dict(env or {})
        self.proc: subprocess.Popen | None = None
        self.port: int | None = None

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def start(self) -> "LiveServer":
        self.port = free_port()
        env = {k: v for k, v in os.environ.items() if not k.startswith("KIN_")}
        env.update({"KIN_DATA_DIR": str(self.data_dir), "KIN_WARM_UP": "before_serving", "PYTHONUNBUFFERED": "1"},
                   **self.extra_env)
        cmd = ([sys.executable, "-m", "app"] if self.serve else [sys.executable, "-m", "uvicorn", "app.main:app"]) + [
            "--host", "127.0.0.1", "--port", str(self.port), "--workers", str(self.workers)]
        self._log = open(self.log_path, "ab")
        self._log_start = self._log.tell()
        self.proc = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=self._log, stderr=subprocess.STDOUT,
                                     start_new_session=True)
        deadline = time.monotonic() + STARTUP_TIMEOUT
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"server exited with {self.proc.returncode}:\n{self.log()}")
            try:
                if httpx.get(self.url + "/health", timeout=2.0).status_code == 200 and self.ready_workers() >= self.workers:
                    return self
            except httpx.HTTPError:
                pass
            time.sleep(0.2)
        self.stop()
        raise RuntimeError(f"server did not answer /health within {STARTUP_TIMEOUT} s:\n{self.log()}")

    def ready_workers(self) -> int:
        """How many worker processes have said that their start-up is complete (in this run's log)."""
        try:
            with open(self.log_path, "rb") as f:
                f.seek(self._log_start)
                return f.read().count(READY_LINE)
        except FileNotFoundError:
            return 0

    def wait_for(self, condition, what: str, timeout: float = 60.0, every: float = 0.05):
        """Poll ``condition()`` until it is true (its value is returned); fail naming ``what`` when
        ``timeout`` seconds pass first or the server exits. A wait on a condition, never a sleep that
        must be long enough: the timeout only stops a test that would otherwise hang."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            value = condition()
            if value:
                return value
            if self.proc is not None and self.proc.poll() is not None:
                raise AssertionError(f"the server exited ({self.proc.returncode}) before {what}:\n{self.log()[-2000:]}")
            time.sleep(every)
        raise AssertionError(f"not within {timeout} s: {what}\n{self.log()[-2000:]}")

    def metric(self, name: str) -> float | None:
        """The value of an unlabelled metric in ``GET /metrics`` (summed over its samples), or None."""
        try:
            text = httpx.get(self.url + "/metrics", timeout=5.0).text
        except httpx.HTTPError:
            return None
        values = [float(line.rsplit(" ", 1)[1]) for line in text.splitlines()
                  if line.startswith(name) and line[len(name):len(name) + 1] in (" ", "{")]
        return sum(values) if values else None

    def kill(self, sig: int = signal.SIGKILL) -> None:
        """Send ``sig`` to the server's process group (the workers it started) and reap it."""
        if self.proc is None or self.proc.returncode is not None:
            return
        try:  # the leader is not reaped yet, so its group id cannot have been reused
            os.killpg(self.proc.pid, sig)
        except ProcessLookupError:
            pass
        try:
            self.proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait(timeout=30)
        self._log.close()

    def stop(self) -> None:
        """Graceful stop (SIGTERM to the group), if still running."""
        self.kill(signal.SIGTERM)

    def log(self) -> str:
        try:
            return self.log_path.read_text(errors="replace")
        except FileNotFoundError:
            return ""

    def __enter__(self) -> "LiveServer":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
