"""Every core: large batches split over threads running the ``nogil`` kernels.

The compiled kernels release the GIL (``nogil=True``), and each configuration (IK: each
target) is computed on its own, with the same arithmetic wherever it falls in a batch (a
single configuration equals its row of a batch bit for bit). So a batch is cut into
contiguous row ranges, one kernel call per range on a pool of threads, each writing its own
rows of the result: the answer is **bit-identical** whatever the number of threads.

How many threads (:func:`thread_count`): the innermost ``with threads(n):`` block of the
calling thread (a context variable), else :func:`set_threads`, else the environment variable
``KIN_THREADS``, else the cores this process may run on (``len(os.sched_getaffinity(0))``).
Batches below ``min_rows`` rows per thread stay on the calling thread (a thread hand-off
costs ~10-50 µs); below two threads' worth they do not even read the thread count (a small
batch, a single configuration: the environment look-up alone cost ~1 µs of a ~2 µs kernel).

>>> import numpy as np
>>> from kinematics import compile_model, default_catalogue
>>> model = default_catalogue().get("ur5")
>>> Q = model.sample_configurations(20_000, np.random.default_rng(0))
>>> with threads(1):
...     one = compile_model(model).fk(Q)
>>> with threads(2):
...     two = compile_model(model).fk(Q)
>>> bool((one == two).all())
True
"""

from __future__ import annotations

import contextlib
import contextvars
import itertools
import os
import threading
from concurrent.futures import ThreadPoolExecutor

from . import cancel
from ..errors import KinematicsError

#: the environment variable naming the thread count
ENV_THREADS = "KIN_THREADS"
#: FK / Jacobian rows a thread must get at least before a batch is split
FK_MIN_ROWS = 8192
#: IK targets per piece (IK targets differ in cost: many small pieces balance the threads)
IK_PIECE_ROWS = 4

_context: contextvars.ContextVar[int | None] = contextvars.ContextVar("kinematics_threads", default=None)
_setting: int | None = None
_lock = threading.Lock()
_pool: ThreadPoolExecutor | None = None
_pool_size = 0


def available_cores() -> int:
    """The cores this process may run on (its CPU affinity), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def _check(n) -> int:
    try:
        n = int(n)
    except (TypeError, ValueError):
        raise KinematicsError(f"the thread count must be a positive integer, got {n!r}") from None
    if n < 1:
        raise KinematicsError(f"the thread count must be a positive integer, got {n}")
    return n


def thread_count() -> int:
    """Threads a large batch is split over now (see the module for the order of the settings)."""
    n = _context.get()
    if n is not None:
        return n
    if _setting is not None:
        return _setting
    env = os.environ.get(ENV_THREADS)
    if env:
        try:
            return _check(env)
        except KinematicsError as exc:
            raise KinematicsError(f"{ENV_THREADS}: {exc}") from None
    return available_cores()


def set_threads(n: int | None) -> None:
    """Set the thread count of the process (None: back to ``KIN_THREADS`` or the cores available)."""
    global _setting
    _setting = None if n is None else _check(n)


@contextlib.contextmanager
def threads(n: int | None):
    """Use ``n`` threads for the batches computed inside the block (this thread and the tasks it
    starts with a copy of its context); None: the process setting."""
    token = _context.set(None if n is None else _check(n))
    try:
        yield
    finally:
        _context.reset(token)


def _forget_pool() -> None:
    """In a forked child the pool's threads do not exist: start a new pool when one is needed."""
    global _pool, _pool_size, _lock
    _pool, _pool_size, _lock = None, 0, threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pool)


def _executor(workers: int) -> ThreadPoolExecutor:
    global _pool, _pool_size
    with _lock:
        if _pool is None or _pool_size < workers:
            old = _pool
            _pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="kinematics")
            _pool_size = workers
            if old is not None:
                old.shutdown(wait=False)
        return _pool


def run_rows(fn, N: int, min_rows: int = FK_MIN_ROWS, piece_rows: int | None = None, align: int = 1,
             n_threads: int | None = None) -> int:
    """Call ``fn(a, b)`` over row ranges covering ``[0, N)`` on up to :func:`thread_count` threads
    (the calling thread is one of them); returns the number of threads used.

    ``min_rows``: rows each thread must get at least (fewer threads otherwise). By default the
    rows are cut into one contiguous range per thread (starts aligned to ``align``); with
    ``piece_rows``, into pieces of that many rows that the threads take in turn (work whose cost
    varies by row). An exception in any range is raised here, after every range has finished.

    Inside a :func:`kinematics.engine.cancel.cancellable` block the rows are always cut into
    pieces (``piece_rows``, else :data:`~kinematics.engine.cancel.CANCEL_PIECE_ROWS`), and the
    token is checked before each piece (:class:`~kinematics.errors.CancelledError`,
    :class:`~kinematics.errors.TimeBudgetError`); the bits of every row are the same.
    """
    token = cancel.current()
    if token is None and n_threads is None and N < 2 * max(1, min_rows):
        # under two threads' worth of rows (a single configuration, a small batch): here, at once,
        # without reading the thread count (its environment look-up costs more than a one-row kernel)
        if N:
            fn(0, N)
        return 1
    t = n_threads if n_threads is not None else thread_count()
    t = min(t, N // max(1, min_rows))
    if token is not None:  # cancellable: pieces, and a check before each (kinematics.engine.cancel)
        token.check()
        if piece_rows is None:
            piece_rows = -(-cancel.CANCEL_PIECE_ROWS // align) * align
        if N <= piece_rows:
            if N:
                fn(0, N)
            return 1
        t = max(t, 1)
    if t <= 1 and token is None:
        if N:
            fn(0, N)
        return 1
    if piece_rows is None:
        step = -(-N // t)
        step = -(-step // align) * align
        bounds = [(a, min(a + step, N)) for a in range(0, N, step)]
        pool = _executor(len(bounds) - 1)
        futures = [pool.submit(fn, a, b) for a, b in bounds[1:]]
        try:
            fn(*bounds[0])
        finally:
            for f in futures:
                f.exception()
        for f in futures:
            f.result()
        return len(bounds)
    pieces = [(a, min(a + piece_rows, N)) for a in range(0, N, piece_rows)]
    counter = itertools.count()

    def worker():
        while True:
            k = next(counter)  # atomic under the GIL
            if k >= len(pieces):
                return
            if token is not None:
                token.check()
            fn(*pieces[k])

    if t <= 1:
        worker()
        return 1
    pool = _executor(t - 1)
    futures = [pool.submit(worker) for _ in range(t - 1)]
    try:
        worker()
    finally:
        for f in futures:
            f.exception()
    for f in futures:
        f.result()
    return t
