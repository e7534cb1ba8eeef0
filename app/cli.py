"""``kinematics serve`` and ``python -m app``: run the REST service under uvicorn.

The command belongs to the service, not the library: it reaches the ``kinematics``
command line through the entry-point group ``kinematics.commands`` (``pyproject.toml``),
so the library never names the app.
"""

from __future__ import annotations

import argparse
import os
import sys

EXIT_OK, EXIT_USAGE = 0, 2
#: the ASGI application uvicorn serves
ASGI_APP = "app.main:app"


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


_DESCRIPTION = ("Serve the REST API: replaces this process with `python -m uvicorn app.main:app`. "
                "Settings come from environment variables (KIN_DATA_DIR, KIN_MAX_BATCH, ...); defaults of the "
                "options below come from HOST, PORT and WEB_CONCURRENCY.")


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
    argv = [sys.executable, "-m", "uvicorn", ASGI_APP,
            "--host", args.host, "--port", str(args.port), "--workers", str(args.workers)]
    sys.stdout.flush()
    sys.stderr.flush()
    os.execv(sys.executable, argv)
    return EXIT_OK  # pragma: no cover - execv does not return


def _fail(message: str) -> int:
    print(f"kinematics serve: error: {message}", file=sys.stderr)
    return EXIT_USAGE


def main(argv: list[str] | None = None) -> int:
    """``python -m app [--host H] [--port P] [--workers N] [--data-dir DIR]``."""
    parser = _options(argparse.ArgumentParser(prog="python -m app", description=_DESCRIPTION))
    args = parser.parse_args(argv)
    return args.func(args)
