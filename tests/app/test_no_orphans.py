"""Nothing a server starts outlives it, however it is started or stopped.

``uvicorn app.main:app`` stopped with SIGTERM used to leave its body-decoder process and
multiprocessing's resource tracker running under PID 1 (uvicorn re-raises the SIGTERM it handled,
which kills the worker before its exit handlers run; the decoder ignored SIGTERM and waited for
jobs forever, and the tracker lives as long as a process holding its pipe does). Each test starts a
real server (uvicorn's own command, as FastAPI apps are usually run), records every process it
started (the decoder, the tracker), stops it one way (SIGTERM or SIGINT to the server, or a
SIGKILL of the worker alone) and waits until none of them is left. It waits on a condition,
never for a fixed time: the timeout only stops a test that would otherwise hang.
"""

from __future__ import annotations

import signal
import time

import psutil
import pytest

from tests.live import LiveServer

pytestmark = pytest.mark.slow

#: seconds the processes a server started may take to go once it is gone
GONE_TIMEOUT = 60.0


def _started_by(pid: int) -> list[psutil.Process]:
    return psutil.Process(pid).children(recursive=True)


def _alive(procs: list[psutil.Process]) -> list[psutil.Process]:
    out = []
    for p in procs:
        try:
            if p.is_running() and p.status() != psutil.STATUS_ZOMBIE:
                out.append(p)
        except psutil.NoSuchProcess:
            pass
    return out


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT, signal.SIGKILL], ids=["sigterm", "sigint", "sigkill"])
def test_the_processes_a_server_started_end_with_it(tmp_path, sig):
    live = LiveServer(tmp_path / "data", tmp_path / "uvicorn.log").start()
    try:
        children = _started_by(live.proc.pid)
        names = " ".join(" ".join(c.cmdline()) for c in children)
        assert "multiprocessing" in names, names  # the decoder (and the tracker) are there to outlive it
        live.proc.send_signal(sig)  # the server alone, not its process group: the way a supervisor stops it
        live.proc.wait(60)
        deadline = time.monotonic() + GONE_TIMEOUT
        while _alive(children) and time.monotonic() < deadline:
            time.sleep(0.05)
        left = [(p.pid, " ".join(p.cmdline())) for p in _alive(children)]
        assert not left, f"left behind after {signal.Signals(sig).name}: {left}\n{live.log()[-2000:]}"
    finally:
        live.kill()


def test_the_processes_of_a_failed_start_end_with_it(tmp_path):
    """A start that fails after the application started (its port is taken: uvicorn's lifespan runs,
    then the bind fails and the process exits) leaves nothing behind either."""
    import os
    import socket
    import subprocess
    import sys

    from tests.paths import REPO

    taken = socket.socket()
    taken.bind(("127.0.0.1", 0))
    taken.listen(1)
    port = taken.getsockname()[1]
    env = {k: v for k, v in os.environ.items() if not k.startswith("KIN_")}
    env.update({"KIN_DATA_DIR": str(tmp_path / "data"), "KIN_WARM_UP": "before_serving", "PYTHONUNBUFFERED": "1"})
    log = open(tmp_path / "uvicorn.log", "wb")
    proc = subprocess.Popen([sys.executable, "-m", "uvicorn", "app.main:app", "--host", "127.0.0.1", "--port",
                             str(port)], cwd=REPO, env=env, stdout=log, stderr=subprocess.STDOUT,
                            start_new_session=True)
    seen: dict[int, psutil.Process] = {}
    try:
        while proc.poll() is None:  # every process it starts, until it exits (the bind fails)
            try:
                for p in _started_by(proc.pid):
                    seen.setdefault(p.pid, p)
            except psutil.NoSuchProcess:
                break
            time.sleep(0.02)
        assert proc.wait(600) != 0
        assert seen, "the failed start started nothing: the test would pass blindly"
        deadline = time.monotonic() + GONE_TIMEOUT
        while _alive(list(seen.values())) and time.monotonic() < deadline:
            time.sleep(0.05)
        text = (tmp_path / "uvicorn.log").read_text(errors="replace")
        assert "address already in use" in text.lower() or "error while attempting to bind" in text.lower(), text[-2000:]
        left = [(p.pid, " ".join(p.cmdline())) for p in _alive(list(seen.values()))]
        assert not left, f"left behind after a failed start: {left}\n{text[-2000:]}"
    finally:
        taken.close()
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
