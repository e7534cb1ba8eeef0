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
