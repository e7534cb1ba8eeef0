"""The service end to end: a real uvicorn on a loopback port, started and stopped here.

- a 10,000-configuration FK request (client encode, HTTP, server, decode) with the binary
  ``.npy`` transport and with each JSON form, against Pinocchio's loop on the same configs;
- single-configuration FK latency (p50) against ``/health`` on the same server;
- requests per second for FK and ``/health`` with 1 and 2 uvicorn workers.
Every loop is bounded in count and time; the server only listens on 127.0.0.1.
"""

from __future__ import annotations

import io
import multiprocessing as mp
import os
import socket
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import orjson
import pinocchio as pin

from kinematics import compile_model
from kinematics.io.catalogue import default_catalogue

from .common import Report, configurations, measure, ms, percentile_times, table, us
from .kernels import _pinocchio

ROOT = Path(__file__).resolve().parent.parent
HOST = "127.0.0.1"
NPY = "application/x-npy"
#: Targets of issue 6.
BATCH_TARGET = 1.5
LATENCY_TARGET = 2.0
#: Seconds to wait for uvicorn to answer /health (a busy shared machine starts it slowly).
STARTUP_TIMEOUT = 240.0
#: Seconds of load per (endpoint, worker count) in the throughput test, and client processes.
LOAD_SECONDS = 3.0
LOAD_CLIENTS = 2
#: Requests per endpoint for the latency percentiles.
LATENCY_REQUESTS = 300


def _free_port() -> int:
    with socket.socket() as s:
        s.bind((HOST, 0))
        return s.getsockname()[1]


@contextmanager
def uvicorn_server(workers: int = 1, env: dict | None = None):
    """A uvicorn serving app.main:app on a free loopback port; yields its base URL (``env``: more
    environment variables of the server)."""
    import httpx

    port = _free_port()
    with tempfile.TemporaryDirectory(prefix="kin-bench-") as data_dir:
        env = dict(os.environ, KIN_DATA_DIR=data_dir, KIN_LOG_LEVEL="warning", **(env or {}))
        proc = subprocess.Popen(
            [sys.executable, "-m", "uvicorn", "app.main:app", "--host", HOST, "--port", str(port),
             "--workers", str(workers), "--log-level", "warning", "--no-access-log"],
            cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
        )
        url = f"http://{HOST}:{port}"
        try:
            deadline = time.monotonic() + STARTUP_TIMEOUT
            while True:
                if proc.poll() is not None:
                    raise RuntimeError(f"uvicorn exited: {proc.stderr.read().decode(errors='replace')[-2000:]}")
                try:
                    if httpx.get(url + "/health", timeout=1.0).status_code == 200:
                        break
                except httpx.HTTPError:
                    pass
                if time.monotonic() > deadline:
                    raise RuntimeError("uvicorn did not answer /health in time")
                time.sleep(0.2)
            yield url
        finally:
            proc.terminate()
            try:
                proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout=5)


def decode_npy(content: bytes) -> np.ndarray:
    """A client's zero-copy ``.npy`` decoding: parse the header, view the bytes (no pickle)."""
    f = io.BytesIO(bytes(content[:4096]))
    version = np.lib.format.read_magic(f)
    read_header = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
    shape, fortran, dtype = read_header(f)
    assert not fortran and not dtype.hasobject
    return np.frombuffer(content, dtype=dtype, offset=f.tell()).reshape(shape)


class StdlibClient:
    """A minimal keep-alive HTTP/1.1 client (``http.client``, TCP_NODELAY) for the binary transport."""

    def __init__(self, url: str):
        import http.client
        from urllib.parse import urlsplit

        parts = urlsplit(url)
        self.conn = http.client.HTTPConnection(parts.hostname, parts.port, timeout=120.0)
        self.conn.connect()
        self.conn.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def post(self, path: str, body: bytes, headers: dict[str, str]):
        """The answer's body: read straight into one uninitialised buffer of its Content-Length
        (no chunk list to join, no zero-filling), which :func:`decode_npy` then views."""
        self.conn.request("POST", path, body=body, headers=headers)
        r = self.conn.getresponse()
        length = r.getheader("Content-Length")
        if r.status != 200 or length is None:
            content = r.read()
            raise RuntimeError(f"HTTP {r.status}: {content[:500]!r}")
        buf = np.empty(int(length), dtype=np.uint8)
        view, got = memoryview(buf), 0
        while got < len(buf):
            n = r.readinto(view[got:])
            if not n:
                raise RuntimeError(f"the answer ended after {got} of {len(buf)} bytes")
            got += n
        return buf

    def close(self) -> None:
        self.conn.close()


def loopback_transfer(nbytes: int, rounds: int = 15) -> float:
    """Best seconds to move ``nbytes`` over a loopback TCP connection with plain sockets (the floor)."""
    import threading

    data = bytes(nbytes)
    srv = socket.socket()
    srv.bind((HOST, 0))
    srv.listen(1)

    def serve():
        conn, _ = srv.accept()
        with conn:
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            while conn.recv(1):
                conn.sendall(data)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    buf = bytearray(nbytes)
    best = float("inf")
    with socket.create_connection((HOST, srv.getsockname()[1])) as cl:
        for _ in range(rounds):
            t = time.perf_counter()
            cl.sendall(b"x")
            view, got = memoryview(buf), 0
            while got < nbytes:
                got += cl.recv_into(view[got:], nbytes - got)
            best = min(best, time.perf_counter() - t)
    thread.join(timeout=5)
    srv.close()
    return best


def batch_request(report: Report, url: str, robot: str = "ur5", n: int = 10_000, rounds: int = 21) -> dict:
    import httpx

    model = default_catalogue().get(robot)
    poe = compile_model(model)
    Q = configurations(model, n)
    _, pm, data, X = _pinocchio(model, Q)
    expected = poe.fk(Q)
    L = expected.shape[1]
    headers = {"Content-Type": NPY, "Accept": NPY}

    def pin_loop():
        for x in X:
            pin.forwardKinematics(pm, data, x)
            pin.updateFramePlacements(pm, data)

    results = {}
    stdlib = StdlibClient(url)
    with httpx.Client(base_url=url, timeout=120.0) as client:
        def npy_call(links="all"):  # stdlib client, zero-copy decoding
            body = io.BytesIO()
            np.save(body, Q, allow_pickle=False)
            path = f"/models/{robot}/fk" + (f"?links={links}" if links else "")
            return decode_npy(stdlib.post(path, body.getvalue(), headers))

        def npy_httpx(links="all"):  # httpx and np.load, as in the README
            body = io.BytesIO()
            np.save(body, Q, allow_pickle=False)
            r = client.post(f"/models/{robot}/fk", params={"links": links} if links else None,
                            content=body.getvalue(), headers=headers)
            r.raise_for_status()
            return np.load(io.BytesIO(r.content), allow_pickle=False)

        for call in (npy_call, npy_httpx):
            got = call()
            assert got.shape == expected.shape and np.max(np.abs(got - expected)) < 1e-12, "npy answer differs"

        def json_call(fmt):
            def call():
                body = orjson.dumps({"q": Q.tolist(), "links": "all", "format": fmt})
                r = client.post(f"/models/{robot}/fk", content=body, headers={"Content-Type": "application/json"})
                r.raise_for_status()
                return orjson.loads(r.content)
            return call

        answer = json_call("matrix")()
        assert len(answer["poses"]) == n, "JSON batch answer has the wrong length"
        wall = time.perf_counter  # client, server and HTTP: wall time
        t = measure({"pin": pin_loop, "npy": npy_call, "npy_leaves": lambda: npy_call(None),
                     "npy_httpx": npy_httpx, "npy_httpx_leaves": lambda: npy_httpx(None),
                     "ours_library": lambda: poe.fk(Q)}, rounds=rounds, min_time=0.0, clock=wall)
        for fmt in ("pose", "matrix", "compact"):
            t[f"json {fmt}"] = measure({fmt: json_call(fmt)}, rounds=2, min_time=0.0, clock=wall)[fmt]
    stdlib.close()
    answer_bytes = n * L * 16 * 8
    t["loopback"] = loopback_transfer(answer_bytes)
    leaves = len(model.leaf_links)
    mib = lambda links: f"{n * links * 16 * 8 / 2**20:.1f} MiB"  # noqa: E731
    rows = [["library call `fk(Q)` (no HTTP)", "-", ms(t["ours_library"]), f"{t['ours_library'] / t['pin']:.2f}", ""],
            [f"plain sockets moving {mib(L)} over loopback (no HTTP, no FK)", mib(L), ms(t["loopback"]),
             f"{t['loopback'] / t['pin']:.2f}", ""]]
    ratio = t["npy"] / t["pin"]
    rows.append(["`.npy` in, `.npy` out (stdlib `http.client`)", mib(L), ms(t["npy"]), f"**{ratio:.2f}**",
                 "yes" if ratio <= BATCH_TARGET else "no"])
    rows.append([f"`.npy` in, `.npy` out, default links (the {leaves} leaf links; `http.client`)", mib(leaves),
                 ms(t["npy_leaves"]), f"{t['npy_leaves'] / t['pin']:.2f}", ""])
    rows.append(["`.npy` in, `.npy` out (httpx, `np.load`)", mib(L), ms(t["npy_httpx"]),
                 f"{t['npy_httpx'] / t['pin']:.2f}", ""])
    rows.append([f"`.npy` in, `.npy` out, default links (httpx, `np.load`)", mib(leaves), ms(t["npy_httpx_leaves"]),
                 f"{t['npy_httpx_leaves'] / t['pin']:.2f}", ""])
    for fmt in ("pose", "matrix", "compact"):
        rows.append([f"JSON in, JSON out, `format: {fmt}` (httpx)", "", ms(t[f"json {fmt}"]),
                     f"{t[f'json {fmt}'] / t['pin']:.2f}", ""])
    rows.append(["Pinocchio loop (same configurations)", "-", ms(t["pin"]), "1.00", ""])
    report.add(
        f"Service: one FK request of {n:,} configurations, all {L} links of {robot}, end to end (ms)",
        table(["transport", "answer size", "time (ms)", "ratio to Pinocchio", f"≤ {BATCH_TARGET}?"], rows),
        "End to end in one client: encode the request (np.save / orjson of `Q.tolist()`), HTTP over "
        "loopback to one uvicorn worker (httptools + uvloop), server-side validation + FK + encoding, and "
        "decoding the answer. Two clients: a keep-alive stdlib `http.client` connection with TCP_NODELAY "
        "reading the answer into one buffer of its Content-Length and viewing it in place (`np.frombuffer` "
        "after the `.npy` header), and httpx + `np.load`. "
        "httpx's reading of a large body costs ≈ 25-30 ms for 13 MiB by itself (measured against a "
        "plain-socket server), so the client library decides most of that row. Wall time, best of a few "
        "interleaved rounds (Pinocchio's loop too).",
    )
    results["npy_ratio"] = ratio
    results.update({k: v for k, v in t.items()})
    server_steps(report, model, Q, t["pin"])
    return results


def server_steps(report: Report, model, Q: np.ndarray, t_pin: float) -> None:
    """Where the server's time goes for the .npy batch (the same calls, in-process, no HTTP)."""
    from app.npy import decode_q
    from app.responses import NpyResponse

    from kinematics import as_batch
    from kinematics.model.joint_values import limit_violations

    poe = compile_model(model)
    body = npy_bytes(Q)
    T = poe.fk(Q)
    answer = npy_bytes(T)
    steps = {
        "decode the .npy body (`app.npy.decode_q`)": lambda: decode_q(body),
        "validate q (`as_batch`)": lambda: as_batch(model, Q),
        "limits report (`X-Out-Of-Limits`: one vectorised comparison)": lambda: limit_violations(model, Q).any(axis=1).sum(),
        "FK of all links (`fk`)": lambda: poe.fk(Q),
        "encode the answer (`NpyResponse`: the header; the array's buffer is sent as is)": lambda: NpyResponse(T),
        "client: decode the answer (`np.frombuffer` after the header)": lambda: decode_npy(answer),
        "client: decode the answer (`np.load`, a copy)": lambda: np.load(io.BytesIO(answer), allow_pickle=False),
    }
    t = measure(steps, rounds=7, min_time=0.01)
    rows = [[name, ms(v), f"{v / t_pin:.2f}"] for name, v in t.items()]
    report.add(
        f"Service: the steps of that request measured in-process ({Q.shape[0]:,} configurations, ms)",
        table(["step", "time (ms)", "ratio to Pinocchio's loop"], rows),
        "The rest of the end-to-end time is HTTP: uvicorn and the client moving the answer over loopback "
        "(plain sockets alone: the loopback row of the table above).",
    )


def npy_bytes(Q: np.ndarray) -> bytes:
    b = io.BytesIO()
    np.save(b, Q, allow_pickle=False)
    return b.getvalue()


def latency(report: Report, url: str, robot: str = "ur5") -> dict:
    import httpx

    model = default_catalogue().get(robot)
    q = configurations(model, 1)[0].tolist()
    with httpx.Client(base_url=url, timeout=30.0) as client:
        def fk():
            r = client.post(f"/models/{robot}/fk", content=orjson.dumps({"q": q}),
                            headers={"Content-Type": "application/json"})
            assert r.status_code == 200, r.text
            return orjson.loads(r.content)

        def health():
            r = client.get("/health")
            assert r.status_code == 200
            return orjson.loads(r.content)

        for _ in range(20):  # warm up
            fk()
            health()
        t_fk, t_h = [], []
        for _ in range(LATENCY_REQUESTS // 50):  # interleave blocks so both see the same load
            t_fk.append(percentile_times(fk, 50))
            t_h.append(percentile_times(health, 50))
    t_fk, t_h = np.concatenate(t_fk), np.concatenate(t_h)
    p = {name: (np.percentile(v, 50), np.percentile(v, 90)) for name, v in (("fk", t_fk), ("health", t_h))}
    ratio = p["fk"][0] / p["health"][0]
    report.add(
        f"Service: single-configuration FK latency vs /health ({robot}, one worker, {len(t_fk)} requests each)",
        table(["request", "p50 (ms)", "p90 (ms)", "p50 ratio to /health", f"≤ {LATENCY_TARGET}?"], [
            [f"POST /models/{robot}/fk (JSON, one q, leaf links, format pose)", ms(p["fk"][0]), ms(p["fk"][1]),
             f"**{ratio:.2f}**", "yes" if ratio <= LATENCY_TARGET else "no"],
            ["GET /health", ms(p["health"][0]), ms(p["health"][1]), "1.00", ""],
        ]),
        "Sequential requests from one keep-alive httpx client over loopback.",
    )
    return {"ratio": ratio, "p50_fk": p["fk"][0], "p50_health": p["health"][0]}


def _load_client(args) -> int:
    url, path, body, seconds = args
    import httpx

    done = 0
    deadline = time.monotonic() + seconds
    with httpx.Client(base_url=url, timeout=30.0) as client:
        while time.monotonic() < deadline:
            if body is None:
                r = client.get(path)
            else:
                r = client.post(path, content=body, headers={"Content-Type": "application/json"})
            if r.status_code == 200:
                done += 1
    return done


def throughput(report: Report, robot: str = "ur5", worker_counts=(1, 2)) -> dict:
    model = default_catalogue().get(robot)
    q = configurations(model, 1)[0].tolist()
    fk_body = orjson.dumps({"q": q})
    rows, results = [], {}
    ctx = mp.get_context("spawn")
    for workers in worker_counts:
        with uvicorn_server(workers) as url:
            with ctx.Pool(LOAD_CLIENTS) as pool:
                pool.map(_load_client, [(url, "/health", None, 0.5)] * LOAD_CLIENTS)  # warm every worker
                pool.map(_load_client, [(url, f"/models/{robot}/fk", fk_body, 0.5)] * LOAD_CLIENTS)
                rps = {}
                for name, path, body in (("fk", f"/models/{robot}/fk", fk_body), ("health", "/health", None)):
                    counts = pool.map(_load_client, [(url, path, body, LOAD_SECONDS)] * LOAD_CLIENTS)
                    rps[name] = sum(counts) / LOAD_SECONDS
        results[workers] = rps
        rows.append([workers, f"{rps['fk']:.0f}", f"{rps['health']:.0f}", f"{rps['fk'] / rps['health']:.2f}"])
    report.add(
        f"Service: requests per second ({LOAD_CLIENTS} client processes, {LOAD_SECONDS:.0f} s each)",
        table(["uvicorn workers", f"FK ({robot}, one q) req/s", "/health req/s", "FK / health"], rows),
        f"Client processes and server workers share this machine's {os.cpu_count()} cores, so the "
        "figures bound what the server alone would do. uvicorn runs with uvloop and httptools (project "
        "dependencies). With the plain asyncio loop and `--workers 2`, uvicorn binds the socket itself with "
        "protocol number 0, so asyncio does not set TCP_NODELAY on accepted connections and keep-alive "
        "requests wait ≈ 40 ms for delayed ACKs (≈ 45 req/s measured before); uvloop sets TCP_NODELAY on "
        "every TCP connection.",
    )
    return results


def run(report: Report, quick: bool = False) -> dict:
    out = {}
    with uvicorn_server(1) as url:
        out["batch"] = batch_request(report, url, n=2_000 if quick else 10_000)
        out["latency"] = latency(report, url)
    out["throughput"] = throughput(report, worker_counts=(1,) if quick else (1, 2))
    return out
