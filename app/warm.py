"""The service process's warm-up: every operation's compiled kernels loaded before a request needs them.

The steps are the library's (:mod:`kinematics.usecases.warm`). With ``KIN_WARM_UP=background`` (the
default) they run in a thread of the worker while it already answers, and then read and compile the
bundled models too (a first request on one pays neither): ``/health`` answers at once, with
``"warm_up": "running"`` until they are done (``"done"``; ``"failed"`` if a step raised, logged). A
warm disk cache loads in a few seconds; the first start on a machine compiles the kernels (minutes on
a busy 2-core machine; ``make install`` and the Docker build do it beforehand).
``KIN_WARM_UP=before_serving`` runs the kernels' steps in the lifespan, so the worker answers nothing
before they are loaded (what the tests' servers do: a request's cost is then never a compilation's).

The kernels belong to the process: one warm-up per process (:func:`process_warm_up`), however many
apps it builds (tests build many). Each step is logged with its duration.
"""

from __future__ import annotations

import logging
import threading
import time

from kinematics.usecases.warm import steps

from .heavy import freeze_heap

log = logging.getLogger("app.warm")

PENDING, RUNNING, DONE, FAILED = "pending", "running", "done", "failed"


class WarmUp:
    """The warm-up of this process: its state, the step it is at, the seconds it took."""

    def __init__(self) -> None:
        self.state = PENDING
        self.step: str | None = None
        self.seconds: float | None = None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._done = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self, background: bool) -> None:
        """Run the steps: in a daemon thread (``background``) or here; nothing if they already ran or run."""
        with self._lock:
            if self.state != PENDING:
                return
            self.state = RUNNING
            self._stop.clear()
            self._done.clear()
        if background:
            log.info("warm-up: loading the compiled kernels in the background, answering meanwhile (/health: "
                     "\"warm_up\": \"running\"); a first start on this machine compiles them, which takes minutes")
            self._thread = threading.Thread(target=self._run, args=(True,), name="kinematics-warm-up", daemon=True)
            self._thread.start()
        else:
            self._run(False)

    def _run(self, catalogue: bool) -> None:
        start = time.perf_counter()
        try:
            for name, run in steps(catalogue=catalogue):
                if self._stop.is_set():  # the app stopped: a later start in this process begins again
                    log.info("warm-up: stopped before %r (the server is shutting down)", name)
                    self.state, self.step = PENDING, None
                    return
                self.step = name
                t0 = time.perf_counter()
                run()
                log.info("warm-up: %s (%.1f s)", name, time.perf_counter() - t0)
            self.seconds = time.perf_counter() - start
            if catalogue:  # in the background, after the worker's start froze its heap (app.heavy.freeze_heap)
                freeze_heap()
            self.state, self.step = DONE, None
            log.info("warm-up: done in %.1f s", self.seconds)
        except Exception:  # noqa: BLE001 - the requests then compile what they need; the service still answers
            self.state = FAILED
            log.exception("warm-up: step %r failed; requests compile what they need on their first use", self.step)
        finally:
            self._done.set()

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the steps are over (done, failed or stopped); False on timeout."""
        return self._done.wait(timeout)

    def stop(self) -> None:
        """Skip the steps not yet started (the one running finishes: a compilation cannot be interrupted);
        a later :meth:`start` begins again."""
        self._stop.set()


_process = WarmUp()

#: a request scope no route matches: matching it visits every route
_NO_ROUTE = {"type": "http", "method": "GET", "path": "/\x00warm-up", "root_path": "", "headers": [], "query_string": b""}


def prepare_routes(app) -> None:
    """Let every route of ``app`` build its request-handling state now: FastAPI builds it on a route's
    first match (each parameter's validator; ~0.8 s for this service's routes, which a first request
    paid), so this matches a path no route takes, which visits them all."""
    for route in app.router.routes:
        try:
            route.matches(_NO_ROUTE)
        except Exception:  # noqa: BLE001 - a route that cannot match this scope prepares on its first request
            log.debug("warm-up: route %r not prepared", route, exc_info=True)


def prepare_routes_in_background(app) -> None:
    """:func:`prepare_routes` in a thread while the worker answers, then the heap frozen again (what it
    built would else be traversed by every full collection: :func:`app.heavy.freeze_heap`)."""
    prepare_routes(app)
    freeze_heap()


def process_warm_up() -> WarmUp:
    """The warm-up of this process (one per process: the compiled kernels are the process's)."""
    return _process
