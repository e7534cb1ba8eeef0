"""Many clients at once against a real server: same answers as sequential calls, no errors.

A real ``uvicorn app.main:app --workers 2`` on a loopback port (two processes sharing one
data directory, as in production). First every reference request is answered once,
sequentially. Then :data:`THREADS` threads send :data:`REQUESTS_PER_THREAD` requests each,
interleaving FK and Jacobians on the same models (a bundled arm, a tree, a DH preset, an
uploaded model) with uploads of distinct URDFs that are read back, used, deleted and shown
gone, and uploads of one shared URDF from every thread at once. Every answer must equal the
sequential one exactly, and no request may fail. The figures (requests, errors, time) are
printed (``pytest -s``).
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

import httpx
import pytest

from tests.live import LiveServer
from tests.paths import CORPUS

pytestmark = pytest.mark.slow

THREADS = 16
REQUESTS_PER_THREAD = 50
WORKERS = 2
TIMEOUT = 120.0

ARM = (CORPUS / "fixture_arm.urdf").read_text()
ARM_Q = {"j1": 0.4, "j2": -1.1, "j3": 0.25}

#: the reference requests: (name, method, path, json); "{arm}" is the uploaded arm's id
REFERENCE_REQUESTS = [
    ("fk_ur5_batch", "/models/ur5/fk",
     {"q": [[0.1 * k, -1.0, 1.2, 0.3, -0.5, 0.7 * k] for k in range(8)], "links": "all"}),
    ("jac_panda", "/models/panda/jacobian",
     {"q": [0.1, -0.4, 0.2, -2.0, 0.3, 1.6, 0.7, 0.02], "link": "panda_link8", "reference": "local_world_aligned"}),
    ("fk_talos_tree", "/models/talos_reduced/fk", None),  # q filled in from the model's dof
    ("fk_dh_preset", "/models/stanford_arm/fk", None),
    ("fk_arm_map", "/models/{arm}/fk", {"q": ARM_Q, "links": "all", "verify": True}),
    ("jac_arm_batch", "/models/{arm}/jacobian", {"q": [[0.1, 0.2, 0.3], [-0.4, 0.5, 0.0]], "reference": "local"}),
]


def _unique_urdf(tag: str) -> str:
    return ARM.replace('name="corpus_arm"', f'name="concurrent_{tag}"')


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    d = tmp_path_factory.mktemp("concurrency")
    with LiveServer(d / "data", d / "server.log", workers=WORKERS) as srv:
        yield srv
    assert "Traceback" not in srv.log(), srv.log()[-5000:]


def test_concurrent_clients_get_sequential_answers(server):
    base = server.url
    with httpx.Client(base_url=base, timeout=TIMEOUT) as c:
        r = c.post("/models", content=ARM, headers={"Content-Type": "application/xml"})
        assert r.status_code in (200, 201), r.text
        arm = r.json()["id"]
        requests = []
        for name, path, body in REFERENCE_REQUESTS:
            if body is None:
                model_id = path.split("/")[2]
                dof = c.get(f"/models/{model_id}").json()["dof"]
                body = {"q": [[0.05 * (i + 1) * (-1) ** i for i in range(dof)], [0.0] * dof], "links": "all"}
            requests.append((name, path.replace("{arm}", arm), body))
        reference = {}
        for name, path, body in requests:
            r = c.post(path, json=body)
            assert r.status_code == 200, (name, r.text)
            reference[name] = r.json()
        # a freshly uploaded copy of the arm (other name, same kinematics) answers like the arm
        arm_fk_body = {"q": ARM_Q, "links": "all"}
        arm_poses = c.post(f"/models/{arm}/fk", json=arm_fk_body).json()["poses"]
        shared = _unique_urdf("shared")

    errors: list[str] = []
    counts = [0] * THREADS
    shared_ids: set[str] = set()
    lock = threading.Lock()
    barrier = threading.Barrier(THREADS)

    def expect(cond: bool, what: str) -> None:
        if not cond:
            with lock:
                errors.append(what)

    def worker(t: int) -> None:
        with httpx.Client(base_url=base, timeout=TIMEOUT) as c:
            def call(method, path, **kw):
                counts[t] += 1
                try:
                    return c.request(method, path, **kw)
                except httpx.HTTPError as exc:
                    expect(False, f"thread {t}: {method} {path}: {type(exc).__name__}: {exc}")
                    return None

            barrier.wait()
            # every thread uploads the same URDF at the same moment: one id, one stored model
            r = call("POST", "/models", content=shared, headers={"Content-Type": "application/xml"})
            if r is not None:
                expect(r.status_code in (200, 201), f"thread {t}: shared upload {r.status_code} {r.text[:200]}")
                if r.status_code in (200, 201):
                    with lock:
                        shared_ids.add(r.json()["id"])
            k = 0
            while counts[t] < REQUESTS_PER_THREAD:
                if k % 4 == 3:  # a distinct upload: read back, used, deleted, gone
                    tag = f"t{t}_k{k}"
                    r = call("POST", "/models", content=_unique_urdf(tag), headers={"Content-Type": "application/xml"})
                    if r is None or r.status_code != 201:
                        expect(False, f"thread {t}: upload {tag}: {r and r.status_code} {r and r.text[:200]}")
                    else:
                        mid = r.json()["id"]
                        g = call("GET", f"/models/{mid}")
                        expect(g is not None and g.status_code == 200 and g.json()["name"] == f"concurrent_{tag}",
                               f"thread {t}: read back {mid}: {g and g.status_code}")
                        f = call("POST", f"/models/{mid}/fk", json=arm_fk_body)
                        expect(f is not None and f.status_code == 200 and f.json()["poses"] == arm_poses,
                               f"thread {t}: fk of {mid}: {f and f.status_code}")
                        d = call("DELETE", f"/models/{mid}")
                        expect(d is not None and d.status_code == 204, f"thread {t}: delete {mid}: {d and d.status_code}")
                        g = call("GET", f"/models/{mid}")
                        expect(g is not None and g.status_code == 404, f"thread {t}: {mid} after delete: {g and g.status_code}")
                else:
                    name, path, body = requests[(t + k) % len(requests)]
                    r = call("POST", path, json=body)
                    if r is not None:
                        ok = r.status_code == 200 and r.json() == reference[name]
                        expect(ok, f"thread {t}: {name}: {r.status_code} differs from the sequential answer")
                k += 1

    threads = [threading.Thread(target=worker, args=(t,)) for t in range(THREADS)]
    start = time.perf_counter()
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    elapsed = time.perf_counter() - start
    total = sum(counts)
    print(f"\nconcurrency: {THREADS} threads x ~{REQUESTS_PER_THREAD} requests = {total} requests, "
          f"{len(errors)} errors, {elapsed:.1f} s ({total / elapsed:.0f} requests/s), {WORKERS} workers")
    assert errors == [], errors[:20]
    assert total >= THREADS * REQUESTS_PER_THREAD
    assert len(shared_ids) == 1

    # afterwards: exactly the arm and the shared upload are stored, and both still answer
    with httpx.Client(base_url=base, timeout=TIMEOUT) as c:
        stored = sorted(m["id"] for m in c.get("/models").json() if m["source"] == "upload")
        assert stored == sorted({arm, *shared_ids})
        for name, path, body in requests:
            assert c.post(path, json=body).json() == reference[name]
        assert c.get("/health").status_code == 200
