"""Cooperative cancellation and time budgets of long computations.

A :class:`Cancellation` is a token a caller hands to a computation: it carries an optional
deadline (a time budget, in seconds from its creation) and can be cancelled from any thread
(a web server does it when its client disconnects). The computation checks it between pieces
of work with :func:`check`: the kernels of one piece run to their end (they are compiled and
hold no Python state to stop), so the work stops within one piece after the token trips. The
pieces: rows of a batch (:func:`kinematics.engine.parallel.run_rows`: FK, Jacobians, IK, in
pieces of :data:`CANCEL_PIECE_ROWS` configurations or :data:`~kinematics.engine.parallel.IK_PIECE_ROWS`
targets), velocity rows, workspace chunks.

The token of the current computation is a context variable, set by ``with cancellable(token):``
(as :func:`kinematics.engine.parallel.threads`); nothing is checked outside such a block, so
the library's behaviour and speed are unchanged for callers that never use one. Over its
deadline :func:`check` raises :class:`~kinematics.errors.TimeBudgetError`; cancelled, it raises
:class:`~kinematics.errors.CancelledError`.

>>> token = Cancellation(timeout=60, setting="request_timeout")
>>> with cancellable(token):
...     check()          # nothing happens: not cancelled, within its time
>>> token.cancel("the client went away")
>>> with cancellable(token):
...     check()
Traceback (most recent call last):
...
kinematics.errors.CancelledError: the computation was cancelled: the client went away
"""

from __future__ import annotations

import contextlib
import contextvars
import threading
import time

from ..errors import CancelledError, TimeBudgetError

#: FK / Jacobian / velocity rows between two checks when a token is active (about a millisecond)
CANCEL_PIECE_ROWS = 8192

_current: contextvars.ContextVar["Cancellation | None"] = contextvars.ContextVar("kinematics_cancellation",
                                                                                 default=None)


class Cancellation:
    """A cancellation token with an optional time budget.

    ``timeout``: seconds from now after which :meth:`check` raises
    :class:`~kinematics.errors.TimeBudgetError` (None: no deadline); ``setting`` names the setting
    the budget comes from (quoted in the error). :meth:`cancel` (thread-safe) makes the next
    :meth:`check` raise :class:`~kinematics.errors.CancelledError`. ``checks`` counts the checks
    made (how far the work went).
    """

    def __init__(self, timeout: float | None = None, *, setting: str = "timeout"):
        self.timeout = None if timeout is None else float(timeout)
        self.setting = setting
        self.started = time.monotonic()
        self.deadline = None if timeout is None else self.started + float(timeout)
        self._event = threading.Event()
        self.reason = ""
        self.checks = 0

    def cancel(self, reason: str = "cancelled by the caller") -> None:
        """Stop the work at its next check."""
        if not self._event.is_set():
            self.reason = reason
            self._event.set()

    @property
    def cancelled(self) -> bool:
        return self._event.is_set()

    @property
    def expired(self) -> bool:
        return self.deadline is not None and time.monotonic() >= self.deadline

    def remaining(self) -> float | None:
        """Seconds left before the deadline (None: no deadline; 0 when past it)."""
        return None if self.deadline is None else max(0.0, self.deadline - time.monotonic())

    def error(self) -> Exception | None:
        """The exception :meth:`check` would raise now, or None."""
        if self._event.is_set():
            return CancelledError(f"the computation was cancelled: {self.reason}")
        if self.expired:
            return TimeBudgetError(
                f"the computation took longer than its time budget of {self.timeout:g} s (the setting "
                f"{self.setting}) and was stopped: send fewer configurations or targets, fewer restarts or "
                "iterations, or fewer samples", setting=self.setting, limit=self.timeout)
        return None

    def check(self) -> None:
        """Raise :class:`~kinematics.errors.CancelledError` or :class:`~kinematics.errors.TimeBudgetError`
        when the work must stop."""
        self.checks += 1
        if self._event.is_set() or (self.deadline is not None and time.monotonic() >= self.deadline):
            raise self.error()


@contextlib.contextmanager
def cancellable(token: Cancellation | None):
    """Make ``token`` the cancellation of the computations in the block (None: none)."""
    reset = _current.set(token)
    try:
        yield token
    finally:
        _current.reset(reset)


def current() -> Cancellation | None:
    """The token of the innermost :func:`cancellable` block of this context, or None."""
    return _current.get()


def check() -> None:
    """Check the current token (nothing when there is none)."""
    token = _current.get()
    if token is not None:
        token.check()
