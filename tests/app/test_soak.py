"""Soak: a bounded mixed load on a real server with 2 workers (``python -m app --workers 2``).

Several client threads send, in a random order, for ``KIN_SOAK_SECONDS`` (default 20 in
``make test``, which every kind of request fills many times; set it higher for a real soak,
e.g. ``KIN_SOAK_SECONDS=900``): uploads of their own URDF (each client
one fixture), FK and Jacobians on it, and its deletion; FK batches (JSON, one large enough for the
decoder process and an answer in parts, and ``.npy``),
Jacobians, IK and workspaces on catalogue robots. Every request goes on a new connection, so
both workers serve all kinds. Checked:

- no 5xx answer, and every answer the expected status;
- every answer **equal, byte for byte, to the answer of a first sequential pass** (the
  computations are deterministic), and the sequential pass's FK equal to ``kinematics.api``;
- the memory (RSS) of each worker flat after warm-up: at the end at most 1.2 x its RSS after
  the first third of the run, plus 32 MiB. RSS at start, after warm-up and at the end are printed.
"""

from __future__ import annotations

import os
import random
import threading
import time
from pathlib import Path

import httpx
import numpy as np
import psutil
import pytest

from kinematics import api
from kinematics.io.catalogue import default_catalogue
from tests.live import LiveServer
from tests.paths import FIXTURES
from tests.helpers import npy_bytes

pytestmark = pytest.mark.slow

SECONDS = float(os.environ.get("KIN_SOAK_SECONDS", "20"))
CLIENTS = 4
#: end RSS <= warm-up RSS x this + SLACK
GROWTH = 1.2
SLACK = 32 * 1024 * 1024
URDFS = ["planar_2r.urdf", "planar_3r.urdf", "spatial_3r.urdf", "tree_mimic.urdf"]
CLOSE = {"Connection": "close"}


def _catalogue_requests() -> dict[str, tuple]:
    """name -> (method, path, kwargs of httpx, expected status)."""
    ur5, panda = default_catalogue().get("ur5"), default_catalogue().get("panda")
    rng = np.random.default_rng(7)
    Q = ur5.sample_configurations(300, rng)
    T = api.fk(ur5, ur5.sample_configurations(60, rng), links=["tool0"]).poses[:, 0]
    return {
        "fk": ("POST", "/models/ur5/fk", {"json": {"q": Q.tolist(), "links": "all"}}, 200),
        "fk_npy": ("POST", "/models/ur5/fk", {"content": npy_bytes(ur5.sample_configurations(20_000, rng)),
                                             "headers": {"Content-Type": "application/x-npy",
                                                         "Accept": "application/x-npy"}}, 200),
        "jacobian": ("POST", "/models/panda/jacobian",
                     {"json": {"q": panda.sample_configurations(200, rng).tolist(), "reference": "local"}}, 200),
        "ik": ("POST", "/models/ur5/ik", {"json": {"target": T.tolist(), "link": "tool0"}}, 200),
        "workspace": ("POST", "/models/panda/workspace", {"json": {"samples": 20_000, "random_seed": 3}}, 200),
        "fk_one": ("POST", "/models/ur5/fk", {"json": {"q": Q[0].tolist()}}, 200),
        # a JSON body over KIN_DECODE_PROCESS_BYTES (the decoder process) and an answer sent in parts
        "fk_big": ("POST", "/models/ur5/fk", {"json": {"q": ur5.sample_configurations(6000, rng).tolist(),
                                                        "links": ["tool0"], "format": "compact"}}, 200),
        "health": ("GET", "/health", {}, 200),
    }


def _upload_requests(urdf: bytes, model_id: str, dof: int) -> list[tuple]:
    """An upload, its use and its deletion, in order: (name, method, path, kwargs, status)."""
    q = [[0.1 * (k + 1) * (-1) ** k for k in range(dof)], [0.3] * dof]
    return [
        ("upload", "POST", "/models", {"content": urdf, "headers": {"Content-Type": "application/xml"}}, (200, 201)),
        ("upload_fk", "POST", f"/models/{model_id}/fk", {"json": {"q": q, "links": "all"}}, 200),
        ("upload_jacobian", "POST", f"/models/{model_id}/jacobian", {"json": {"q": q}}, 200),
        ("delete", "DELETE", f"/models/{model_id}", {}, 204),
        ("deleted", "GET", f"/models/{model_id}", {}, 404),
    ]


def _send(client: httpx.Client, method: str, path: str, kwargs: dict) -> httpx.Response:
    kwargs = dict(kwargs)
    kwargs["headers"] = {**CLOSE, **kwargs.get("headers", {})}
    return client.request(method, path, **kwargs)


def _workers(server_pid: int) -> list[psutil.Process]:
    return [p for p in psutil.Process(server_pid).children()
            if any("spawn_main" in part for part in p.cmdline())]


def test_soak_two_workers_mixed_load(tmp_path: Path):
    catalogue = _catalogue_requests()
    live = LiveServer(tmp_path / "data", tmp_path / "uvicorn.log", workers=2, serve=True,
                      env={"KIN_LOG_LEVEL": "warning"})
    with live, httpx.Client(base_url=live.url, timeout=120) as http:
        workers = _workers(live.proc.pid)
        assert len(workers) == 2, [p.cmdline() for p in psutil.Process(live.proc.pid).children()]
        rss = {"start": [w.memory_info().rss for w in workers]}

        # the sequential pass: the expected answer of every request
        expected: dict[str, bytes] = {}
        for name, (method, path, kwargs, status) in catalogue.items():
            r = _send(http, method, path, kwargs)
            assert r.status_code == status, (name, r.text)
            expected[name] = r.content
        fk = np.array([[link["matrix"] for link in c.values()] for c in httpx.Response(200, content=expected["fk"])
                       .json()["poses"]])
        Q = np.array(catalogue["fk"][2]["json"]["q"])
        np.testing.assert_allclose(fk, api.fk(default_catalogue().get("ur5"), Q, links="all").poses, rtol=0, atol=0)
        uploads = []
        for k in range(CLIENTS):
            urdf = (FIXTURES / URDFS[k]).read_bytes()
            r = _send(http, "POST", "/models", {"content": urdf, "headers": {"Content-Type": "application/xml"}})
            assert r.status_code in (200, 201), r.text
            model_id, dof = r.json()["id"], len(r.json()["joint_names"])
            steps = _upload_requests(urdf, model_id, dof)
            answers = {}
            for name, method, path, kwargs, status in steps[1:]:
                r = _send(http, method, path, kwargs)
                assert r.status_code == status, (name, r.text)
                answers[name] = r.content
            uploads.append((steps, answers))

        # the concurrent phase
        failures: list[str] = []
        counts: dict[str, int] = {}
        lock = threading.Lock()
        stop = time.monotonic() + SECONDS
        warm_at = time.monotonic() + SECONDS / 3

        def client(k: int) -> None:
            rnd = random.Random(k)
            steps, answers = uploads[k]
            with httpx.Client(base_url=live.url, timeout=120) as c:
                while time.monotonic() < stop and len(failures) < 20:
                    if rnd.random() < 0.3:  # the upload cycle, in order
                        batch = [(n, m, p, kw, s) for n, m, p, kw, s in steps]
                    else:
                        name = rnd.choice(list(catalogue))
                        method, path, kwargs, status = catalogue[name]
                        batch = [(name, method, path, kwargs, status)]
                    for name, method, path, kwargs, status in batch:
                        try:
                            r = _send(c, method, path, kwargs)
                        except httpx.HTTPError as exc:
                            failures.append(f"{name}: {exc!r}")
                            continue
                        ok = r.status_code in status if isinstance(status, tuple) else r.status_code == status
                        same = name in ("upload", "deleted", "delete") or r.content == \
                            (expected.get(name) or answers.get(name))
                        with lock:
                            counts[name] = counts.get(name, 0) + 1
                        if r.status_code >= 500 or not ok or not same:
                            failures.append(f"{name}: {r.status_code} {'same' if same else 'DIFFERENT'} "
                                            f"{r.text[:300]}")

        threads = [threading.Thread(target=client, args=(k,)) for k in range(CLIENTS)]
        for t in threads:
            t.start()
        while time.monotonic() < warm_at:
            time.sleep(0.2)
        rss["warm-up"] = [w.memory_info().rss for w in workers]
        for t in threads:
            t.join(SECONDS + 300)
        rss["end"] = [w.memory_info().rss for w in workers]
        log = live.log()

    mib = {k: [round(v / 2**20, 1) for v in vals] for k, vals in rss.items()}
    print(f"\nsoak {SECONDS:g} s, {CLIENTS} clients, 2 workers: {sum(counts.values())} requests {counts}")
    print(f"RSS of the workers (MiB): start {mib['start']}, after warm-up {mib['warm-up']}, end {mib['end']}")
    assert not failures, failures[:10]
    assert "Traceback" not in log, log[-3000:]
    assert all(counts.get(name, 0) > 0 for name in ("fk", "fk_big", "jacobian", "ik", "workspace", "upload", "delete")), \
        counts
    for warm, end in zip(rss["warm-up"], rss["end"]):
        assert end <= warm * GROWTH + SLACK, mib
