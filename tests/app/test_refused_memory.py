"""A refused request leaves the server's memory where it was: the requests that grew a server by
gigabytes before they were bounded (every IK solution of 10^5 targets, a Cartesian path of 10^5
targets, 10^6 calibration rows, 10^6 collision configurations) are refused by their counts before
their work (413; the path: 422, take larger steps). The worker's resident memory stays where it was;
its body decoder, which decodes the 10^5 IK targets before the solution count refuses them, keeps the
high-water mark of that first decode (pymalloc's arenas; the rest goes back to the system,
``malloc_trim``) and grows no further over more rounds."""

from __future__ import annotations

from pathlib import Path

import httpx
import numpy as np
import psutil
import pytest

from kinematics import compile_model, default_catalogue
from tests.live import LiveServer

pytestmark = pytest.mark.slow

MIB = 2 ** 20
#: growth of the process tree allowed over rounds of refusals (a bound that growth per request would pass)
SLACK = 64 * MIB
#: rounds of the same refusals
ROUNDS = 8


def _tree_rss(pid: int) -> int:
    root = psutil.Process(pid)
    return sum(p.memory_info().rss for p in [root, *root.children(recursive=True)])


def _bodies() -> list[tuple[str, dict, dict, int]]:
    ur5 = default_catalogue().get("ur5")
    T = compile_model(ur5).fk(np.array([[0.3, -1.0, 1.2, -0.5, 0.8, 0.2]]), ["tool0"])[0, 0]
    moved = T.copy()
    moved[0, 3] += 1.0
    target = np.round(T, 12).tolist()
    return [
        # 10^5 targets x up to 256 solutions each (limits respected): over max_ik_solutions before any work
        ("/models/ur5/ik", {"json": {"link": "tool0", "target": [target] * 100_000, "solutions": "all"}}, {}, 413),
        # a 1 m line in steps of 10 um: 10^5 targets, more than a path may have (max_batch: 422 naming the step)
        ("/models/ur5/ik/path", {"json": {"link": "tool0", "waypoints": [target, np.round(moved, 12).tolist()],
                                          "seed": [0.3, -1.0, 1.2, -0.5, 0.8, 0.2],
                                          "step": {"position": 1e-5}}}, {}, 422),
        # 10^6 CSV rows: over max_measurements, counted before they are read
        ("/models/ur5/calibrate", {"content": ("q1,q2,q3,q4,q5,q6,x,y,z\n" + "0.1,0.2,0.3,0.4,0.5,0.6,0.1,0.2,0.3\n"
                                               * 1_000_000).encode(),
                                   "headers": {"Content-Type": "text/csv"}}, {"link": "tool0"}, 413),
        # 10^6 configurations in JSON: over max_batch (here 10^5), counted in the raw bytes
        ("/models/ur5/collision", {"json": {"q": [[0.1] * 6] * 1_000_000}}, {}, 413),
    ]


def test_refused_requests_leave_the_server_memory_where_it_was(tmp_path: Path):
    bodies = _bodies()
    live = LiveServer(tmp_path / "data", tmp_path / "uvicorn.log",
                      env={"KIN_MAX_BATCH": "100000", "KIN_LOG_LEVEL": "warning"})
    with live, httpx.Client(base_url=live.url, timeout=300) as http:
        worker = psutil.Process(live.proc.pid)
        before, worker_before = _tree_rss(live.proc.pid), worker.memory_info().rss

        def refuse_all() -> None:
            for path, kwargs, params, status in bodies:
                r = http.post(path, params=params, **kwargs)
                assert r.status_code == status, (path, r.status_code, r.text[:500])
                assert r.headers["content-type"].startswith("application/problem+json")

        trace = []
        for _ in range(ROUNDS):
            refuse_all()
            trace.append((_tree_rss(live.proc.pid), worker.memory_info().rss))
        assert http.get("/health").status_code == 200
    tree = [t for t, _ in trace]
    print(f"\nRSS (MiB) before: tree {before / MIB:.0f}, worker {worker_before / MIB:.0f}; after each round of "
          f"refusals: tree {[round(t / MIB) for t in tree]}, worker {[round(w / MIB) for _, w in trace]}")
    worker = [w for _, w in trace]
    half = len(worker) // 2
    # the worker (the server that answers) keeps the high-water mark of the first large bodies (the
    # allocator's arenas; the rest goes back to the system) and does not grow with more refusals
    assert max(worker) - worker_before <= 4 * SLACK, [round(w / MIB) for w in worker]
    assert max(worker[half:]) <= max(worker[:half]) + SLACK, [round(w / MIB) for w in worker]
    # the whole tree (the decoder's arenas too) stays far below what these requests took before they
    # were bounded (2 to 6 GB each)
    assert max(tree) - before <= 16 * SLACK, [round(t / MIB) for t in tree]
