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
        env.update({"KIN_DATA_DIR": str(self.data_dir), "PYTHONUNBUFFERED": "1"}, **self.extra_env)
        cmd = ([sys.executable, "-m", "app"] if self.serve else [sys.executable, "-m", "uvicorn", "app.main:app"]) + [
            "--host", "127.0.0.1", "--port", str(self.port), "--workers", str(self.workers)]
        self._log = open(self.log_path, "ab")
        self.proc = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=self._log, stderr=subprocess.STDOUT,
                                     start_new_session=True)
        deadline = time.monotonic() + STARTUP_TIMEOUT
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"server exited with {self.proc.returncode}:\n{self.log()}")
            try:
                if httpx.get(self.url + "/health", timeout=2.0).status_code == 200:
                    if self.workers > 1:
                        time.sleep(1.0)  # let the other workers finish their start-up
                    return self
            except httpx.HTTPError:
                pass
            time.sleep(0.2)
        self.stop()
        raise RuntimeError(f"server did not answer /health within {STARTUP_TIMEOUT} s:\n{self.log()}")

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
