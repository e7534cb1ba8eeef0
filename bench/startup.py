"""The service's start: seconds from ``python -m app`` (what ``make serve`` runs) to its first /health
answer and to the end of its warm-up, with a warm numba cache and with an empty one, and what the
first requests cost after it (``python -m bench.startup``).

Each start is a new one-worker server on a free loopback port with an empty data directory; the
clock starts when the process is spawned. Three moments:

- ``/health``: the first 200 answer (the worker serves; the kernels may still be loading), in wall
  seconds and in CPU seconds of the server process until then (what the start costs on an idle
  machine: on a busy one the wall time is several times the CPU time);
- ``warm``: the first /health that says ``"warm_up": "done"`` (every operation's kernels loaded,
  the bundled models read and compiled: ``app/warm.py``);
- the first request of each operation once warm, against the median of the next ones (a first
  request that compiled a kernel would stand out by seconds).

``warm cache``: numba's cache as ``kinematics warm-up`` (``make install``) leaves it. ``cold cache``:
``NUMBA_CACHE_DIR`` pointed at an empty directory, as on a machine where nothing was compiled yet:
the kernels compile in the background while the server answers. Options: ``--warm N``, ``--cold N``
(runs of each; a cold run takes minutes), ``--output FILE`` (the tables in markdown, with the
machine's load).
"""

from __future__ import annotations

import argparse
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx

from .service import HOST, ROOT, _free_port

#: the longest a start may take (a cold one compiles every kernel: minutes on a busy 2-core machine)
DEADLINE = 3600.0
#: seconds between two /health polls
POLL = 0.05
#: requests timed after the warm-up: (name, method, path, JSON body); the first of each against the next ones
REQUESTS = (
    ("FK, one q", "POST", "/models/ur5/fk", {"q": [0.3, -1.0, 1.2, -0.5, 0.8, 0.2]}),
    ("Jacobian, one q", "POST", "/models/ur5/jacobian", {"q": [0.3, -1.0, 1.2, -0.5, 0.8, 0.2], "link": "tool0"}),
    ("IK, one target", "POST", "/models/ur5/ik",
     {"link": "tool0", "target": {"xyz": [0.4, 0.1, 0.3], "rpy": [3.1, 0.0, 0.0]}}),
    ("IK, every solution", "POST", "/models/ur5/ik",
     {"link": "tool0", "target": {"xyz": [0.4, 0.1, 0.3], "rpy": [3.1, 0.0, 0.0]}, "solutions": "all"}),
)
#: requests after the first one of each operation (their median is the reference)
AGAIN = 5


def start_once(cold: bool) -> dict:
    """One start: seconds to /health and to the warm-up's end, and each request's first and later cost."""
    port = _free_port()
    url = f"http://{HOST}:{port}"
    with tempfile.TemporaryDirectory(prefix="kin-start-") as tmp:
        env = {k: v for k, v in os.environ.items() if not k.startswith("KIN_") and k != "NUMBA_CACHE_DIR"}
        env.update(KIN_DATA_DIR=str(Path(tmp) / "data"), KIN_WARM_UP="background")
        if cold:
            env["NUMBA_CACHE_DIR"] = str(Path(tmp) / "numba-cache")
        t0 = time.perf_counter()
        proc = subprocess.Popen([sys.executable, "-m", "app", "--host", HOST, "--port", str(port)], cwd=ROOT,
                                env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                start_new_session=True)
        try:
            health = warm = None
            with httpx.Client(base_url=url, timeout=600.0) as client:
                while warm is None:
                    if proc.poll() is not None:
                        raise RuntimeError(f"the server exited with {proc.returncode}")
                    if time.perf_counter() - t0 > DEADLINE:
                        raise RuntimeError("the server did not warm up in time")
                    try:
                        r = client.get("/health", timeout=5.0)
                    except httpx.HTTPError:
                        time.sleep(POLL)
                        continue
                    now = time.perf_counter() - t0
                    if r.status_code == 200:
                        if health is None:
                            health, cpu = now, _cpu_seconds(proc.pid)
                        if r.json().get("warm_up", "done") != "running":
                            warm = now
                    time.sleep(POLL)
                first = {}
                for name, method, path, body in REQUESTS:
                    times = []
                    for _ in range(1 + AGAIN):
                        t = time.perf_counter()
                        r = client.request(method, path, json=body)
                        times.append(time.perf_counter() - t)
                        assert r.status_code == 200, r.text
                    first[name] = (times[0], statistics.median(times[1:]))
        finally:
            os.killpg(proc.pid, signal.SIGTERM)
            try:
                proc.wait(timeout=60)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
    return {"health": health, "cpu": cpu, "warm": warm, "first": first}


def _cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of process ``pid`` so far."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _min_median(values: list[float], digits: int = 2) -> list[str]:
    return [f"{min(values):.{digits}f}", f"{statistics.median(values):.{digits}f}"]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m bench.startup", description=__doc__.splitlines()[0])
    p.add_argument("--warm", type=int, default=5, help="starts with numba's cache warm (default 5)")
    p.add_argument("--cold", type=int, default=1, help="starts with an empty numba cache (default 1; minutes each)")
    p.add_argument("--output", help="write the tables to this markdown file")
    a = p.parse_args(argv)
    # the warm cache: what `make install` leaves (fast when it is warm already)
    subprocess.run([sys.executable, "-m", "kinematics", "warm-up"], cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
    load = os.getloadavg()
    runs = {"warm cache": [start_once(False) for _ in range(a.warm)],
            "cold cache": [start_once(True) for _ in range(a.cold)]}
    lines = [f"Load average at start: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} ({os.cpu_count()} cores); "
             f"`python -m bench.startup --warm {a.warm} --cold {a.cold}`.", "",
             "| cache | starts | /health min (s) | /health median (s) | its CPU min (s) | its CPU median (s) "
             "| warm-up done min (s) | warm-up done median (s) |",
             "|---|---|---|---|---|---|---|---|"]
    for kind, starts in runs.items():
        if starts:
            lines.append(f"| {kind} | {len(starts)} | " + " | ".join(
                _min_median([s["health"] for s in starts]) + _min_median([s["cpu"] for s in starts])
                + _min_median([s["warm"] for s in starts])) + " |")
    lines += ["", f"First request of each operation once warm, against the median of the next {AGAIN} "
              "(milliseconds; median over the starts):", "",
              "| request | cache | first (ms) | next (ms) |", "|---|---|---|---|"]
    for kind, starts in runs.items():
        for name, *_ in REQUESTS if starts else ():
            firsts = [s["first"][name][0] * 1e3 for s in starts]
            nexts = [s["first"][name][1] * 1e3 for s in starts]
            lines.append(f"| {name} | {kind} | {statistics.median(firsts):.1f} | {statistics.median(nexts):.1f} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if a.output:
        Path(a.output).write_text("# Start-up of the service\n\n" + __doc__.split("\n\n", 1)[1] + "\n" + text)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
