"""``kinematics serve`` and ``python -m app``: run the REST service under uvicorn.

The command belongs to the service, not the library: it reaches the ``kinematics``
command line through the entry-point group ``kinematics.commands`` (``pyproject.toml``),
so the library never names the app.

uvicorn runs in this process (the container's PID 1 is this process, so it gets SIGTERM).
On SIGTERM (or SIGINT) the server stops accepting connections, lets the requests in flight
finish for up to ``KIN_SHUTDOWN_TIMEOUT`` seconds (uvicorn's ``timeout_graceful_shutdown``;
then their work is cancelled) and exits with status 0. With several workers the supervising
process closes its copy of the listening socket at once, so that new connections are refused,
not left waiting in the backlog of a socket nobody accepts on any more.

No window in which the signal kills: Python's default action for SIGTERM ends the process at
once, and uvicorn installs its handlers only when it starts serving (after the imports).
:func:`hold_signals` (the first statement of ``python -m app``; :func:`run_uvicorn` for
``kinematics serve``) replaces that default by a handler that remembers the signal, and the
server (or the supervisor) takes the remembered signals over when its own handlers are in
place, so a SIGTERM during the start-up stops the server as one during service does. Because
uvicorn re-raises the signal it handled once it is done, and the handler that is then in place
is this one, a graceful stop exits with 0: an exit by the signal (-15, 143) means a kill.
The worker processes of ``--workers N`` are uvicorn's own: one still starting holds no
connection (it accepts only once its handlers are in place), so the supervisor's SIGTERM to it
loses nothing.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import sys

EXIT_OK, EXIT_USAGE = 0, 2
#: the ASGI application uvicorn serves
ASGI_APP = "app.main:app"


#: the signals that stop the server (held until uvicorn handles them)
STOP_SIGNALS = (signal.SIGTERM, signal.SIGINT)
_held: list[int] = []


def _hold(sig: int, frame) -> None:
    _held.append(sig)


def hold_signals() -> None:
    """Remember SIGTERM / SIGINT from now on instead of dying of them (the server takes the
    remembered ones over once it handles signals itself). Main thread only; idempotent."""
    for sig in STOP_SIGNALS:
        if signal.getsignal(sig) is not _hold:
            signal.signal(sig, _hold)


def take_held() -> list[int]:
    """The signals held so far (oldest first), forgotten here."""
    taken = list(_held)
    del _held[:len(taken)]
    return taken


def _env_int(name: str, default: int) -> int:
    try:
        return int(os.environ.get(name, default))
    except ValueError:
        return default


def _options(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    p.add_argument("--host", default=os.environ.get("HOST", "127.0.0.1"), help="address to bind (default 127.0.0.1)")
    p.add_argument("--port", type=int, default=_env_int("PORT", 8000), help="port (default 8000)")
    p.add_argument("--workers", type=int, default=_env_int("WEB_CONCURRENCY", 1), help="worker processes (default 1)")
    p.add_argument("--data-dir", metavar="DIR", help="directory of uploaded models (sets KIN_DATA_DIR)")
    p.set_defaults(func=run_serve)
    return p


_DESCRIPTION = ("Serve the REST API: runs uvicorn serving app.main:app in this process. "
                "Settings come from environment variables (KIN_DATA_DIR, KIN_MAX_BATCH, ...); defaults of the "
                "options below come from HOST, PORT and WEB_CONCURRENCY. SIGTERM lets requests in flight finish "
                "for up to KIN_SHUTDOWN_TIMEOUT seconds (default 30).")


def register(sub) -> None:
    """Add ``serve`` to the ``kinematics`` command line (entry point ``kinematics.commands``)."""
    _options(sub.add_parser("serve", help="run the REST service (uvicorn app.main:app)", description=_DESCRIPTION))


def run_serve(args) -> int:
    """Replace this process by uvicorn serving :data:`ASGI_APP`."""
    if not 0 < args.port < 65536:
        return _fail(f"--port {args.port} is not a port number")
    if args.workers < 1:
        return _fail("--workers must be at least 1")
    if args.data_dir:
        os.environ["KIN_DATA_DIR"] = args.data_dir
    from pydantic import ValidationError

    from .settings import Settings

    try:
        timeout = Settings().shutdown_timeout
    except ValidationError as exc:
        return _fail(f"settings: {exc}")
    return run_uvicorn(host=args.host, port=args.port, workers=args.workers, shutdown_timeout=timeout)


def run_uvicorn(*, host: str, port: int, workers: int, shutdown_timeout: float) -> int:
    """Serve :data:`ASGI_APP` until SIGTERM / SIGINT (see the module for the shutdown)."""
    hold_signals()
    import uvicorn
    from uvicorn.supervisors import Multiprocess

    class Server(uvicorn.Server):
        """uvicorn's server, which takes over the signals held before its handlers were in place."""

        stopped_before_start = False

        @contextlib.contextmanager
        def capture_signals(self):
            with super().capture_signals():
                for sig in take_held():
                    self.handle_exit(sig, None)
                yield

        async def startup(self, sockets=None):
            if self.should_exit:  # told to stop before it started: nothing to warm up, serve or drain
                self.stopped_before_start = True
                return
            await super().startup(sockets=sockets)

    class Supervisor(Multiprocess):
        """uvicorn's supervisor of several workers, which refuses new connections once told to stop
        (and takes over the signals held before its handlers were in place)."""

        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            self.signal_queue.extend(take_held())

        def _stop_listening(self) -> None:
            for sock in self.sockets:
                sock.close()

        def handle_term(self) -> None:
            self._stop_listening()
            super().handle_term()

        def handle_int(self) -> None:
            self._stop_listening()
            super().handle_int()

    config = uvicorn.Config(ASGI_APP, host=host, port=port, workers=workers,
                            timeout_graceful_shutdown=shutdown_timeout)
    if workers == 1:
        server = Server(config)
        server.run()
        return EXIT_OK if server.started or server.stopped_before_start else 3
    Supervisor(config, sockets=[config.bind_socket()]).run()
    return EXIT_OK


def _fail(message: str) -> int:
    print(f"kinematics serve: error: {message}", file=sys.stderr)
    return EXIT_USAGE


def main(argv: list[str] | None = None) -> int:
    """``python -m app [--host H] [--port P] [--workers N] [--data-dir DIR]``."""
    parser = _options(argparse.ArgumentParser(prog="python -m app", description=_DESCRIPTION))
    args = parser.parse_args(argv)
    return args.func(args)
