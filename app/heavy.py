"""Heavy work off the event loop, under a time budget, stopped when its client goes away.

:func:`run_heavy` runs a route's computation (large FK / Jacobian / velocity batches, IK,
workspaces, the parsing of large JSON bodies) on the worker's *heavy* thread pool: at most
``KIN_MAX_HEAVY_JOBS`` at a time per worker process, the others wait their turn. The light
requests (``/health``, a single configuration) never queue behind them: they run on the event
loop or on the default thread pool, which heavy work does not use, and the threads of the heavy
pool run at a lower scheduling priority (``KIN_HEAVY_NICE``) so that the CPU goes first to the
threads that answer light requests.

Each request's heavy calls share one :class:`kinematics.usecases.Cancellation` with the time budget
``KIN_REQUEST_TIMEOUT`` (counted from when its first heavy call, the decode of a large body, is
queued: :func:`request_token`). The library checks it between
pieces of the work (``kinematics.engine.cancel``); while the work runs, the event loop polls the
connection every :data:`POLL_SECONDS` and cancels the token when the client has disconnected, so
no CPU is spent on an answer nobody reads. Over its budget the request ends with 503
``time-budget-exceeded`` (the problem names the setting and the limit); a cancelled one with 499
(nobody reads it). When the server stops (SIGTERM) and its graceful-shutdown timeout
(``KIN_SHUTDOWN_TIMEOUT``) runs out, uvicorn cancels the request's task and the token with it.
"""

from __future__ import annotations

import asyncio
import contextvars
import logging
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable

from fastapi import Request

from kinematics import api
from kinematics.errors import TimeBudgetError

from . import metrics

log = logging.getLogger("app.heavy")

#: seconds between two looks at the client's connection (and at the clock) while heavy work runs
POLL_SECONDS = 0.05
#: the name of the time-budget setting, as errors quote it
SETTING = "KIN_REQUEST_TIMEOUT"

_lock = threading.Lock()
_pools: dict[tuple[int, int, int], ThreadPoolExecutor] = {}

#: heavy calls started and cancelled in this process (tests and metrics read them)
STATS = {"started": 0, "cancelled": 0, "timed_out": 0}


def _lower_priority(nice: int) -> None:
    """Lower this thread's scheduling priority by ``nice`` (Linux: nice values are per thread)."""
    if nice > 0 and hasattr(os, "setpriority"):
        try:
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), min(19, os.getpriority(os.PRIO_PROCESS, 0) + nice))
        except OSError:  # pragma: no cover - not allowed here
            pass


def heavy_pool(jobs: int, nice: int) -> ThreadPoolExecutor:
    """The process's pool of heavy threads (one per concurrent heavy job)."""
    key = (os.getpid(), jobs, nice)
    with _lock:
        pool = _pools.get(key)
        if pool is None:
            pool = _pools[key] = ThreadPoolExecutor(max_workers=jobs, thread_name_prefix="heavy",
                                                    initializer=_lower_priority, initargs=(nice,))
        return pool


def _call(token: api.Cancellation, state: dict, fn: Callable, args: tuple) -> Any:
    state["started"] = True
    with metrics.HEAVY_RUNNING.track_inprogress(), api.cancellable(token):
        token.check()  # cancelled or out of time while it waited for a thread
        return fn(*args)


def request_token(request: Request) -> api.Cancellation:
    """The request's one :class:`~kinematics.usecases.Cancellation`, made on its first heavy call: the
    decode of its body and its work share the budget ``KIN_REQUEST_TIMEOUT`` (the work does not get a
    fresh one after a long decode)."""
    token = getattr(request.state, "kin_cancellation", None)
    if token is None:
        token = request.state.kin_cancellation = api.Cancellation(request.app.state.settings.request_timeout,
                                                                  setting=SETTING)
    return token


async def run_heavy(request: Request, fn: Callable, *args: Any, waits: bool = False) -> Any:
    """``fn(*args)`` on the heavy pool, under the request's time budget and cancelled with its client.

    ``waits``: the work runs in another process (closed forms) and this thread only waits for it:
    it runs on the loop's default executor and takes no heavy slot."""
    settings = request.app.state.settings
    token = request_token(request)
    state = {"started": False}
    pool = None if waits else heavy_pool(settings.max_heavy_jobs, settings.heavy_nice)
    ctx = contextvars.copy_context()  # the request id and the thread count go with the work
    future = asyncio.get_running_loop().run_in_executor(pool, ctx.run, _call, token, state, fn, args)
    STATS["started"] += 1
    try:
        while True:
            done, _ = await asyncio.wait({future}, timeout=POLL_SECONDS)
            if done:
                return future.result()
            if not token.cancelled and await request.is_disconnected():
                token.cancel("the client disconnected")
                STATS["cancelled"] += 1
                log.info("client disconnected: %s %s stopped", request.method, request.url.path)
            if (token.cancelled or token.expired) and not state["started"]:
                future.cancel()  # still queued: it will not run (if it just started, it stops at once)
                raise token.error()
    except TimeBudgetError:
        STATS["timed_out"] += 1
        raise
    except asyncio.CancelledError:  # the server is stopping and its graceful-shutdown time is over
        token.cancel("the server is shutting down")
        raise


def configure_process(settings) -> None:
    """Process-wide settings of a worker, once it has started (imports done, kernels loaded).

    - The GIL's switch interval (``KIN_SWITCH_INTERVAL``): how long the event loop may wait for
      the GIL while a heavy thread runs Python code.
    - BLAS threads (``KIN_BLAS_THREADS``, default 1: :func:`limit_blas_threads`).
    - ``gc.freeze()``: the objects of the start-up (modules, numba's and Pinocchio's tables: most
      of the heap) move to the permanent generation, which the cyclic collector no longer
      traverses. A full collection holds the GIL throughout; over the whole heap it took 30-130 ms
      and ran every few hundred milliseconds while a large JSON answer was built (100,000s of
      dicts), stalling the event loop each time; over what is left, a few milliseconds.
    """
    import gc
    import sys

    global _frozen
    sys.setswitchinterval(settings.switch_interval)
    limit_blas_threads(settings.blas_threads)
    if not _frozen:  # once per process (a test process starts many apps)
        freeze_heap()
        _frozen = True


_frozen = False


def limit_blas_threads(threads: int) -> None:
    """At most ``threads`` BLAS / LAPACK threads in this process (0: leave the library's default).

    OpenBLAS starts a thread per core and its threads spin, busy, between calls: a calibration's
    factorisations in two heavy threads kept both cores of a 2-core machine spinning, and the event
    loop waited for a core: /health's p99 under four calibrations was 290-900 ms, 18 ms with one BLAS
    thread (max 0.7-2.7 s -> 60 ms; load average 9-10 on the machine). The heavy pool and the
    workers are the parallelism; BLAS inside one request adds none worth the loop's latency."""
    if threads <= 0:
        return
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - a slimmer install: the BLAS default stays
        log.warning("threadpoolctl is not installed: BLAS keeps its own thread count (KIN_BLAS_THREADS ignored)")
        return
    threadpool_limits(limits=threads, user_api="blas")


def freeze_heap() -> None:
    """Collect, then move every object alive to the permanent generation (``gc.freeze()``), which
    the cyclic collector no longer traverses: at the start (:func:`configure_process`) and again when
    a background warm-up and the routes' preparation end (``app.warm``, ``app.main``). They run while
    the worker answers, after the first freeze, and left ~135,000 objects that every full collection
    traversed: ~50-100 ms holding the GIL, the event loop stalled, whenever one came during heavy work
    (/health's p99 under load was about that). This collection (~50 ms, once) happens instead."""
    import gc

    gc.collect()
    gc.freeze()


#: JSON bodies up to this many bytes are parsed on the event loop (well under a millisecond);
#: larger ones (a batch) are parsed off the loop
INLINE_BODY_BYTES = 64 * 1024
#: the request fields that hold a batch: decoded into arrays by the decoder process
BATCH_FIELDS = {"q": 2, "qdot": 2, "target": 3}

_decoders: dict[int, Any] = {}


def _quiet_child() -> None:
    """The decoder process leaves SIGINT / SIGTERM to its worker, and ends with it.

    It ends when the worker ends, however the worker does (a graceful stop, uvicorn re-raising the
    SIGTERM it handled, which kills the worker before its exit handlers run, a SIGKILL, a failed
    start): a thread of the decoder waits on the worker's sentinel (a pipe only the worker holds
    open, closed by the kernel when it dies) and then exits the process. Without it the decoder,
    blocked on its job queue (whose write end it holds itself), lived on under PID 1, and with it
    multiprocessing's resource tracker (which ends when the last process holding its pipe does).
    ``prctl(PR_SET_PDEATHSIG)`` would not do: it fires when the *thread* that started the decoder
    ends (a test client's event-loop thread), not the process."""
    import multiprocessing
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    parent = multiprocessing.parent_process()
    if parent is not None:
        threading.Thread(target=_exit_with, args=(parent,), name="exit-with-worker", daemon=True).start()


def _exit_with(parent) -> None:
    """Wait for ``parent`` (a :func:`multiprocessing.parent_process`) to end, then end this process."""
    parent.join()
    os._exit(0)


#: the batch fields a large JSON body's items are counted in before it is decoded: the setting that
#: bounds them, what they are, and how many containers open at a batch's first item (fewer: one item,
#: a vector of q or a 4x4 target)
COUNTED_FIELDS = {"q": ("max_batch", "configurations", 1), "qdot": ("max_batch", "configurations", 1),
                  "target": ("max_batch", "targets", 2), "measurements": ("max_measurements", "measurements", 0)}


def over_count(body: bytes, limits: dict[str, int | None]) -> tuple[str, int, str, str] | None:
    """``(setting, n, what, field)`` of the first batch field of ``body`` whose items, counted in the
    raw bytes (:func:`app.json_count.top_level_counts`: no decode, memory bounded), are over
    ``limits[setting]``; None when none is."""
    from .json_count import top_level_counts

    for field, (items, depth) in top_level_counts(body, COUNTED_FIELDS).items():
        setting, what, batch_depth = COUNTED_FIELDS[field]
        n = items if depth >= batch_depth else 1
        limit = limits.get(setting)
        if limit is not None and n > limit:
            return setting, n, what, field
    return None


def decode_json(schema_name: str, body: bytes, limits: dict[str, int | None] | None = None) -> tuple[str, Any]:
    """In the decoder process: ``("ok", fields)`` of ``body`` validated by ``app.schemas.<schema_name>``
    (``model_dump()``; the batch fields as float arrays when they are plain numeric batches), or
    ``("invalid", errors)`` (pydantic's errors, as the app's handler reports them), or, before any
    decoding, ``("too-large", (setting, n, what, field))`` when a batch field holds more items than
    ``limits`` (settings by name) allow (:func:`over_count`)."""
    import numpy as np
    from pydantic import ValidationError

    from . import schemas

    over = over_count(body, limits) if limits else None
    if over is not None:
        return "too-large", over
    try:
        model = getattr(schemas, schema_name).model_validate_json(body)
    except ValidationError as exc:
        return "invalid", exc.errors(include_url=False)
    data = model.model_dump()
    del model
    for name, ndim in BATCH_FIELDS.items():
        value = data.get(name)
        if isinstance(value, list) and value and isinstance(value[0], list):
            try:
                arr = np.array(value, dtype=float)
            except (TypeError, ValueError):  # ragged or maps: the library names what is wrong
                continue
            if arr.ndim == ndim:
                data[name] = arr
    if len(body) >= TRIM_BYTES:
        release_freed_memory()
    return "ok", data


#: a decode of a body this large (bytes) gives the memory it freed back to the system after it
TRIM_BYTES = 1 << 20


def release_freed_memory() -> None:
    """Give the heap's free memory back to the system (glibc's ``malloc_trim``): the objects of a
    large decode (a validated model and its lists, hundreds of MB for 10^5 IK targets) are freed
    when it ends, but the allocator keeps their pages, so a process that decoded one large body
    (and whose request was then refused) would stay that large. Nothing where the C library has no
    ``malloc_trim``."""
    import ctypes
    import ctypes.util

    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        libc.malloc_trim(0)
    except (OSError, AttributeError):
        pass


def _decoder():
    from concurrent.futures import ProcessPoolExecutor
    import multiprocessing

    with _lock:
        pool = _decoders.get(os.getpid())
        if pool is None:
            pool = _decoders[os.getpid()] = ProcessPoolExecutor(
                max_workers=1, mp_context=multiprocessing.get_context("spawn"), initializer=_quiet_child)
        return pool


#: the decoder process's first job, a batch of this many IK targets (~260 KB): its first real body
#: then does not pay for the first large transfer and decode of a fresh process
_WARM_TARGETS = 1000


def _warm_body() -> bytes:
    import json

    pose = [[1.0, 0.0, 0.0, 0.1], [0.0, 1.0, 0.0, 0.2], [0.0, 0.0, 1.0, 0.3], [0.0, 0.0, 0.0, 1.0]]
    return json.dumps({"target": [pose] * _WARM_TARGETS, "link": "tool0"}).encode()


def _warm_decoder(body: bytes) -> int:
    """In the decoder process, its first job: decode ``body`` (the imports, the first large decode),
    then move everything alive to the cyclic collector's permanent generation (``gc.freeze()``,
    as each worker does: :func:`configure_process`): else the first real body's decode met a full
    collection of the fresh heap (~0.2 s on a busy machine). Its process id."""
    import gc

    decode_json("IKRequest", body)
    gc.collect()
    gc.freeze()
    return os.getpid()


def start_decoder(settings):
    """Start the worker's decoder process now (with the server), not on the first large body:
    spawning it and importing the schemas there took about 1.4 s, which the first request over
    ``KIN_DECODE_PROCESS_BYTES`` paid. Its first job is a large body, sent and answered the way a
    request's is. A future of that job (the lifespan waits for it, so that a server that answers
    is warm); None when the decoder is switched off (``0``)."""
    if not settings.decode_process_bytes:
        return None
    return _decoder().submit(_warm_decoder, _warm_body())


def _decode_elsewhere(schema_name: str, body: bytes, limits: dict[str, int | None]) -> tuple[str, Any]:
    """:func:`decode_json` in the worker's decoder process (its own GIL), here if that process is broken."""
    from concurrent.futures.process import BrokenProcessPool

    try:
        return _decoder().submit(decode_json, schema_name, body, limits).result()
    except BrokenProcessPool:  # killed (out of memory?): a new one next time, this body decoded here
        with _lock:
            _decoders.pop(os.getpid(), None)
        return decode_json(schema_name, body, limits)


async def parse_body(request: Request, schema, body: bytes) -> dict[str, Any]:
    """The fields of a JSON ``body`` validated by ``schema`` (a model of :mod:`app.schemas`), as
    ``model_dump()`` gives them: on the event loop for a small body; else decoded by the worker's
    decoder process, as heavy work. Why a process: pydantic (like any JSON parser) holds the GIL for
    the whole of a decode, ~90 ms for 10,000 IK targets, during which no other thread of the worker,
    the event loop included, can run; in another process the loop goes on answering. Its batch
    fields (``q``, ``qdot``, ``target``) may come back as float arrays, which the library reads as
    it reads the lists."""
    settings = request.app.state.settings
    if len(body) <= INLINE_BODY_BYTES:
        return schema.model_validate_json(body).model_dump()
    limits = {"max_batch": settings.max_batch, "max_measurements": settings.max_measurements}
    if settings.decode_process_bytes and len(body) > settings.decode_process_bytes:
        status, data = await run_heavy(request, _decode_elsewhere, schema.__name__, body, limits)
    else:
        status, data = await run_heavy(request, decode_json, schema.__name__, body, limits)
    if status == "too-large":
        from kinematics.errors import BudgetError

        setting, n, what, field = data
        raise BudgetError(f"{field} holds {n} {what} (counted in the body before decoding it); the limit "
                          f"({setting}) is {limits[setting]}", budget=setting.removeprefix("max_").replace("_", "-"),
                          field=field, limit=limits[setting])
    if status == "invalid":
        from fastapi.exceptions import RequestValidationError

        raise RequestValidationError(data)
    return data
