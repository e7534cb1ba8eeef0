"""Logging of the service: text (the default) or one JSON object per line (``KIN_LOG_FORMAT=json``).

JSON records carry ``time`` (UTC, ISO 8601, milliseconds), ``level``, ``logger``, ``message``,
``request_id`` (``-`` outside a request), ``pid`` (which worker), every field a record was given with ``extra=``
(the access log's ``method``, ``path``, ``route``, ``status``, ``duration_ms``, ``client``,
``problem``, ``detail``), and for an error logged with its exception ``exception`` (its class
and message) and ``traceback``. In JSON mode the service writes its own access log
(``app.access``, :class:`app.middleware.RequestContext`) and uvicorn's text access log is
switched off; uvicorn's own messages (start-up, shutdown) are formatted as JSON too.
"""

from __future__ import annotations

import json
import logging
import traceback
from datetime import datetime, timezone

from .errors import RequestIdFilter

#: attributes every LogRecord has; anything else on a record came from ``extra=``
_STANDARD = frozenset(logging.LogRecord("", 0, "", 0, "", None, None).__dict__) | {"message", "asctime", "request_id"}
TEXT_FORMAT = "%(levelname)s:     %(name)s: [%(request_id)s] %(message)s"


class JsonFormatter(logging.Formatter):
    """One JSON object per record (see the module docstring)."""

    def format(self, record: logging.LogRecord) -> str:
        out = {
            "time": datetime.fromtimestamp(record.created, timezone.utc).isoformat(timespec="milliseconds"),
            "level": record.levelname.lower(),
            "logger": record.name,
            "message": record.getMessage(),
            "request_id": getattr(record, "request_id", "-"),
            "pid": record.process,
        }
        for key, value in record.__dict__.items():
            if key not in _STANDARD and not key.startswith("_"):
                out[key] = value if isinstance(value, (str, int, float, bool, type(None))) else str(value)
        if record.exc_info and record.exc_info[0] is not None:
            exc_type, exc, tb = record.exc_info
            out["exception"] = f"{exc_type.__name__}: {exc}"
            out["traceback"] = "".join(traceback.format_exception(exc_type, exc, tb))
        return json.dumps(out, ensure_ascii=False, default=str)


def reset() -> None:
    """Undo :func:`configure`'s JSON mode (tests that build a JSON-logging app in-process)."""
    logger = logging.getLogger("app")
    for handler in [h for h in logger.handlers if isinstance(h, _JsonHandler)]:
        logger.removeHandler(handler)
    logger.propagate = True
    logging.getLogger("uvicorn.access").disabled = False


class _JsonHandler(logging.StreamHandler):
    """The stderr handler the service installs in JSON mode (one per logger, found again by type)."""


def configure(level: str, fmt: str = "text") -> None:
    """Level and format of the ``app`` loggers (``app``, ``app.access``, ``app.errors``, ...)."""
    logger = logging.getLogger("app")
    logger.setLevel(level.upper())
    if fmt == "json":
        if not any(isinstance(h, _JsonHandler) for h in logger.handlers):
            handler = _JsonHandler()
            handler.addFilter(RequestIdFilter())
            handler.setFormatter(JsonFormatter())
            logger.addHandler(handler)
        logger.propagate = False  # one line per record, not a second (text) one from the root's handlers
        for name in ("uvicorn", "uvicorn.error"):
            for handler in logging.getLogger(name).handlers:
                handler.addFilter(RequestIdFilter())
                handler.setFormatter(JsonFormatter())
        logging.getLogger("uvicorn.access").disabled = True  # replaced by app.access
        return
    if not logger.handlers and not logging.getLogger().handlers:
        handler = logging.StreamHandler()
        handler.addFilter(RequestIdFilter())
        handler.setFormatter(logging.Formatter(TEXT_FORMAT))
        logger.addHandler(handler)
