"""One configuration at a time, with the spread over repeated runs (``--only single``).

A single configuration costs a few microseconds, of which most is fixed overhead (argument
checks, name look-ups, numba's dispatcher, the result's allocation): the figure moves with
the machine's load from run to run, so one lucky run says little. Every row here is measured
in :data:`REPEATS` interleaved repeats of ``N`` calls each (all rows in turn, so that each
repeat sees the same conditions), and the table gives the per-call time's minimum, median
and 90th percentile over the repeats, with the ratio of the medians to Pinocchio's.

- ``compile_model(model).fk(Q, [link])`` with one row (the batch path, as a library user calls it);
- ``kinematics.fk_function`` / ``jacobian_function`` (bound to the model and the link);
- the batch Jacobian ``compile_model(model).jacobian(Q, link)`` with one row;
- Pinocchio: ``forwardKinematics`` + ``updateFramePlacement`` (the one frame) and
  ``computeFrameJacobian`` (``WORLD``), on a pre-converted q;
- the service: ``POST /models/{id}/fk`` with one configuration against ``GET /health`` on a live
  one-worker uvicorn (``python -m uvicorn app.main:app``, loopback, one keep-alive client), and
  the same two requests with the app called in-process as an ASGI application (the worker's own
  CPU time per request, without the client, uvicorn and the loopback).

In-process rows use the CPU time of the benchmarking thread (:data:`bench.common.CLOCK`);
the service rows use wall time (the request crosses two processes).
"""

from __future__ import annotations

import time

import numpy as np

from .common import CLOCK, Report, configurations, run_parts, table

#: repeats of every measurement (the spread is over these)
REPEATS = 7
#: calls per repeat of an in-process row
CALLS = 20_000
#: requests per repeat of a service row
REQUESTS = 60
#: robots and links of the in-process table
ROBOTS = (("ur5", "tool0"), ("panda", "panda_hand_tcp"))
#: the service's single-configuration FK should cost at most this multiple of /health (issue: 1.3)
SERVICE_TARGET = 1.3
#: fk_function / jacobian_function should cost at most this multiple of Pinocchio's single call
LIBRARY_TARGET = 1.5


def spread(fns: dict, repeats: int = REPEATS, calls: int = CALLS, clock=CLOCK) -> dict[str, np.ndarray]:
    """Seconds per call of each function in each of ``repeats`` interleaved repeats of ``calls`` calls."""
    for fn in fns.values():  # warm: first calls, caches, the dispatcher's type cache
        for _ in range(100):
            fn()
    out = {name: np.empty(repeats) for name in fns}
    for r in range(repeats):
        for name, fn in fns.items():
            t0 = clock()
            for _ in range(calls):
                fn()
            out[name][r] = (clock() - t0) / calls
    return out


def _stats(v: np.ndarray, unit: float = 1e6, digits: int = 2) -> list[str]:
    return [f"{np.min(v) * unit:.{digits}f}", f"{np.median(v) * unit:.{digits}f}", f"{np.percentile(v, 90) * unit:.{digits}f}"]


def _fk_health_rows(robot: str, med: dict[str, np.ndarray], unit: float, digits: int) -> list[list[str]]:
    """The service tables' two rows: one configuration's FK and /health, min / median / p90 of the
    per-repeat seconds ``med`` in ``unit`` (1e3: ms, 1e6: µs)."""
    return [[f"POST /models/{robot}/fk (JSON, one q)", *_stats(med["fk"], unit, digits)],
            ["GET /health", *_stats(med["health"], unit, digits)]]


def _ratio_cells(ratio: np.ndarray) -> list[str]:
    """Min, median (bold) and p90 of the per-repeat ratios FK / health."""
    return [f"{ratio.min():.2f}", f"**{np.median(ratio):.2f}**", f"{np.percentile(ratio, 90):.2f}"]


def library_table(report: Report, quick: bool) -> list[dict]:
    import pinocchio as pin

    from kinematics import compile_model, default_catalogue, fk_function, jacobian_function
    from kinematics.verify.pinocchio import reference_for

    calls = CALLS // 10 if quick else CALLS
    rows, out = [], []
    for rid, link in ROBOTS:
        model = default_catalogue().get(rid)
        poe = compile_model(model)
        q = configurations(model, 1)[0]
        Q1 = q[None].copy()
        ref = reference_for(model)
        pm = ref.pin_model
        data = pm.createData()
        x = ref.to_pinocchio_q(q)
        fid = ref.frame_ids[link]
        fk1 = fk_function(poe, link)
        J1 = jacobian_function(poe, link, "world")
        world = pin.ReferenceFrame.WORLD
        pin.forwardKinematics(pm, data, x)
        pin.updateFramePlacement(pm, data, fid)
        # the same answers (bit for bit between our paths, 1e-9 against Pinocchio)
        assert np.array_equal(fk1(q), compile_model(model).fk(Q1, [link])[0, 0])
        assert np.array_equal(J1(q), poe.jacobian(Q1, link)[0])
        assert np.abs(fk1(q) - ref.poses(q)[link]).max() < 1e-9

        def pin_fk():
            pin.forwardKinematics(pm, data, x)
            pin.updateFramePlacement(pm, data, fid)

        t = spread({
            "compile_model(model).fk(Q, [link]), 1 row": lambda: compile_model(model).fk(Q1, [link]),
            "kinematics.fk_function: f(q)": lambda: fk1(q),
            "Pinocchio forwardKinematics + updateFramePlacement": pin_fk,
            "compile_model(model).jacobian(Q, link), 1 row": lambda: compile_model(model).jacobian(Q1, link),
            "kinematics.jacobian_function: J(q)": lambda: J1(q),
            "Pinocchio computeFrameJacobian (WORLD)": lambda: pin.computeFrameJacobian(pm, data, x, fid, world),
        }, calls=calls)
        names = list(t)
        pin_of = {n: (names[2] if i < 3 else names[5]) for i, n in enumerate(names)}
        for name in names:
            ratio = np.median(t[name]) / np.median(t[pin_of[name]])
            rows.append([rid, name, *_stats(t[name]), "" if name == pin_of[name] else f"{ratio:.2f}",
                         ("yes" if ratio <= LIBRARY_TARGET else "no") if "_function" in name else ""])
        out.append({"robot": rid, **{name: float(np.median(v)) for name, v in t.items()}})
    report.add(f"One configuration in-process: µs per call over {REPEATS} repeats of {calls:,} calls",
               table(["robot", "call", "min", "median", "p90", "median / Pinocchio's", f"≤ {LIBRARY_TARGET}?"], rows),
               "CPU time of the benchmarking thread; the repeats are interleaved (every row in turn), so the "
               "spread is the machine's, seen by every row alike. The batch path `compile_model(model).fk` "
               "checks its arguments, resolves the link names (cached per list of names) and calls the batch "
               "kernel; `fk_function` binds all of that once and makes one call of a compiled entry.")
    return out


def service_table(report: Report, quick: bool, robot: str = "ur5") -> dict:
    import httpx
    import orjson

    from kinematics.io.catalogue import default_catalogue

    from .service import uvicorn_server

    n = REQUESTS // 3 if quick else REQUESTS
    model = default_catalogue().get(robot)
    body = orjson.dumps({"q": configurations(model, 1)[0].tolist()})
    headers = {"Content-Type": "application/json"}
    with uvicorn_server(1) as url, httpx.Client(base_url=url, timeout=30.0) as client:
        def fk():
            r = client.post(f"/models/{robot}/fk", content=body, headers=headers)
            assert r.status_code == 200, r.text

        def health():
            assert client.get("/health").status_code == 200

        for _ in range(30):
            fk()
            health()
        med = {"fk": np.empty(REPEATS), "health": np.empty(REPEATS)}
        for r in range(REPEATS):
            for name, fn in (("fk", fk), ("health", health)):
                times = np.empty(n)
                for i in range(n):
                    t0 = time.perf_counter()
                    fn()
                    times[i] = time.perf_counter() - t0
                med[name][r] = np.median(times)
    ratio = med["fk"] / med["health"]
    report.add(f"Service: one configuration's FK against /health ({robot}, live one-worker uvicorn; "
               f"per-repeat median latency over {REPEATS} repeats of {n} requests each)",
               table(["request", "min (ms)", "median (ms)", "p90 (ms)"], _fk_health_rows(robot, med, 1e3, 3))
               + "\n\n" + table(["ratio FK / health (per repeat)", "min", "median", "p90", f"median ≤ {SERVICE_TARGET}?"], [
                   ["", *_ratio_cells(ratio), "yes" if np.median(ratio) <= SERVICE_TARGET else "no"]]),
               "Wall time of sequential requests from one keep-alive httpx client over loopback (client time "
               "included); each repeat alternates a block of FK requests and a block of /health requests.")
    return {"ratio_median": float(np.median(ratio)), "fk_median": float(np.median(med["fk"])),
            "health_median": float(np.median(med["health"]))}


def asgi_table(report: Report, quick: bool, robot: str = "ur5") -> dict:
    """The service's own work per request, without the network, uvicorn or the client: the app
    called as an ASGI application in this process (its lifespan run), CPU time of this thread."""
    import asyncio
    import tempfile

    import orjson

    from kinematics.io.catalogue import default_catalogue

    n = REQUESTS * 10 // (3 if quick else 1)
    model = default_catalogue().get(robot)
    body = orjson.dumps({"q": configurations(model, 1)[0].tolist()})
    fk_headers = [(b"host", b"bench"), (b"content-type", b"application/json"),
                  (b"content-length", str(len(body)).encode())]

    def scope(method: str, path: str, headers) -> dict:
        return {"type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1", "method": method,
                "scheme": "http", "path": path, "raw_path": path.encode(), "query_string": b"", "root_path": "",
                "headers": headers, "client": ("127.0.0.1", 1), "server": ("127.0.0.1", 80)}

    async def main(app) -> dict:
        async def call(method, path, payload, headers):
            async def receive():
                return {"type": "http.request", "body": payload, "more_body": False}

            status = []

            async def send(message):
                if message["type"] == "http.response.start":
                    status.append(message["status"])

            await app(scope(method, path, headers), receive, send)
            assert status == [200], status

        rows = {"fk": np.empty(REPEATS), "health": np.empty(REPEATS)}
        async with app.router.lifespan_context(app):
            for _ in range(50):
                await call("POST", f"/models/{robot}/fk", body, fk_headers)
                await call("GET", "/health", b"", [(b"host", b"bench")])
            for r in range(REPEATS):
                for name, args in (("fk", ("POST", f"/models/{robot}/fk", body, fk_headers)),
                                   ("health", ("GET", "/health", b"", [(b"host", b"bench")]))):
                    t0 = CLOCK()
                    for _ in range(n):
                        await call(*args)
                    rows[name][r] = (CLOCK() - t0) / n
        return rows

    from app.main import create_app
    from app.settings import Settings

    with tempfile.TemporaryDirectory(prefix="kin-bench-") as data_dir:
        med = asyncio.run(main(create_app(Settings(data_dir=data_dir, decode_process_bytes=0))))
    ratio = med["fk"] / med["health"]
    report.add(f"Service work per request in-process ({robot}; the app called as ASGI, no network; µs of CPU "
               f"per request over {REPEATS} repeats of {n} requests)",
               table(["request", "min", "median", "p90"],
                     _fk_health_rows(robot, med, 1e6, 1) + [["ratio FK / health", *_ratio_cells(ratio)]]),
               "CPU time of the benchmarking thread: what the worker itself spends on a request (routing, "
               "middleware, reading, the use case, the JSON answer), which the live table's wall times add "
               "the client, uvicorn and the loopback to; it moves far less with the machine's load.")
    return {"fk_median": float(np.median(med["fk"])), "health_median": float(np.median(med["health"]))}


def run(report: Report, quick: bool = False) -> dict:
    return {"library": library_table(report, quick), "service": service_table(report, quick),
            "asgi": asgi_table(report, quick)}


if __name__ == "__main__":  # pragma: no cover
    run_parts("python -m bench.single", __doc__,
              {"library": library_table, "service": service_table, "asgi": asgi_table},
              default="library,service")
