"""The time limit of closed forms: the derivation runs in a worker process killed after the
limit or when the caller is cancelled (:func:`run_with_timeout`, :func:`derive`)."""

from __future__ import annotations

import math
import multiprocessing
import time
import traceback
from typing import Any, Callable, Sequence

from ...errors import KinematicsError, SymbolicError, SymbolicTimeoutError
from ..task import TaskRepresentation
from .chains import SymbolicChain
from .codegen import FORMATS, render
from .composition import ClosedForms, closed_forms

#: time limit of :func:`run_with_timeout` when the caller gives none (seconds)
DEFAULT_TIMEOUT = 60.0

_CONTEXT = None


def _context():
    global _CONTEXT
    if _CONTEXT is None:
        methods = multiprocessing.get_all_start_methods()
        ctx = multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")
        if ctx.get_start_method() == "forkserver":
            ctx.set_forkserver_preload([__name__])
        _CONTEXT = ctx
    return _CONTEXT


def _worker(conn, fn, args) -> None:
    try:
        message = ("ok", fn(*args))
    except KinematicsError as exc:
        message = ("error", type(exc).__name__, str(exc))
    except RecursionError:
        message = ("error", "SymbolicError", "the expressions are too deeply nested to handle; "
                   "ask with simplify: false or for a shorter chain")
    except BaseException:  # noqa: BLE001 - reported to the parent, which raises
        message = ("bug", traceback.format_exc())
    try:
        conn.send(message)
    except Exception:  # noqa: BLE001 - e.g. an answer that cannot be pickled
        conn.send(("bug", traceback.format_exc()))
    finally:
        conn.close()


#: seconds between two looks at the caller's cancellation token while the worker runs
CANCEL_POLL_SECONDS = 0.05


def run_with_timeout(fn: Callable, args: tuple, timeout: float | None):
    """``fn(*args)`` in a worker process killed after ``timeout`` seconds
    (:class:`~kinematics.errors.SymbolicTimeoutError`); ``timeout=None`` runs it here, unbounded.

    The workers fork from a server process that has sympy loaded (``forkserver``), so a call
    costs a fork, not an import. ``fn``, ``args`` and the result travel by pickle. As with any
    use of :mod:`multiprocessing`, a script that calls this must guard its top level with
    ``if __name__ == "__main__":`` (each worker imports the main module under another name).
    Inside a :func:`kinematics.engine.cancel.cancellable` block the worker is also killed when the
    token is cancelled or its time budget runs out (its error is raised).
    """
    if timeout is None:
        return fn(*args)
    if not (isinstance(timeout, (int, float)) and math.isfinite(timeout) and timeout > 0):
        raise SymbolicError(f"timeout: {timeout!r} is not a positive number of seconds")
    from ...engine import cancel

    token = cancel.current()  # a caller's cancellation (a client that went away) also kills the worker
    ctx = _context()
    receiver, sender = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_worker, args=(sender, fn, args), daemon=True)
    proc.start()
    sender.close()
    try:
        deadline = time.monotonic() + timeout
        answered = receiver.poll(timeout if token is None else min(timeout, CANCEL_POLL_SECONDS))
        while not answered and token is not None and time.monotonic() < deadline:
            token.check()
            answered = receiver.poll(max(0.0, min(deadline - time.monotonic(), CANCEL_POLL_SECONDS)))
        if not answered:
            raise SymbolicTimeoutError(
                f"the closed forms took longer than the time limit of {timeout:g} s; ask with simplify: false "
                "(the expanded forms come fast), for fewer results (what), or for a shorter chain", timeout=timeout)
        try:
            message = receiver.recv()
        except EOFError:
            raise SymbolicError("the closed-form worker ended without an answer: out of memory (ask with simplify: "
                                "false or for a shorter chain), or a script that calls this at import time (guard "
                                "it with `if __name__ == '__main__':`, as multiprocessing requires)") from None
    finally:
        if proc.is_alive():
            proc.kill()
        proc.join(5)
        receiver.close()
    if message[0] == "ok":
        return message[1]
    if message[0] == "error":
        from ... import errors

        cls = getattr(errors, message[1], None)
        try:
            exc = cls(message[2]) if isinstance(cls, type) and issubclass(cls, KinematicsError) else None
        except TypeError:  # a class with required keyword arguments
            exc = None
        raise exc if exc is not None else SymbolicError(message[2])
    raise RuntimeError(f"the closed-form worker failed:\n{message[1]}")


def _job(chain: SymbolicChain, what: tuple[str, ...], simplify: bool, task: TaskRepresentation | None, fmt: str,
         prefix: str) -> tuple[ClosedForms, dict[str, Any]]:
    forms = closed_forms(chain, what, simplify, task)
    return forms, render(forms, fmt, prefix)


def derive(chain: SymbolicChain, *, what: Sequence[str] = ("transforms",), simplify: bool = True,
           task: TaskRepresentation | None = None, fmt: str = "latex", prefix: str = "",
           timeout: float | None = DEFAULT_TIMEOUT) -> tuple[ClosedForms, dict[str, Any]]:
    """:func:`closed_forms` and :func:`render` under a time limit (:func:`run_with_timeout`)."""
    if fmt not in FORMATS:
        raise SymbolicError(f"format: {fmt!r} is not one of {list(FORMATS)}")
    what = tuple(dict.fromkeys(what))
    return run_with_timeout(_job, (chain, what, bool(simplify), task, fmt, prefix), timeout)
