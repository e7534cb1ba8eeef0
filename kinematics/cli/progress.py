"""Progress bars for long CLI work: shown on a terminal, silent when piped."""

from __future__ import annotations

import os
import sys

from tqdm import tqdm


#: the bar's width and the screen's height on a terminal that gives none (a pseudo-terminal of 0 x 0,
#: as `docker run -t` or `script` make one: tqdm draws nothing there)
FALLBACK_COLUMNS, FALLBACK_ROWS = 80, 24


def progress(iterable=None, **kwargs):
    """A tqdm bar on stderr when stderr is a terminal; otherwise the bare iterable."""
    kwargs.setdefault("file", sys.stderr)
    kwargs.setdefault("disable", not sys.stderr.isatty())
    kwargs.setdefault("leave", False)
    if not kwargs["disable"] and not _columns(kwargs["file"]):
        kwargs.setdefault("ncols", FALLBACK_COLUMNS)
        kwargs.setdefault("nrows", FALLBACK_ROWS)
    return tqdm(iterable, **kwargs)


def _columns(stream) -> int:
    """The width of the terminal ``stream`` is (0 when it says none or cannot say)."""
    try:
        return os.get_terminal_size(stream.fileno()).columns
    except (OSError, ValueError, AttributeError):
        return 0


#: rows per update of a bar over work done a chunk at a time (IK: about a second of work)
BAR_STEP = 1000


def bar_steps(n: int, step: int = BAR_STEP) -> list[slice]:
    """``n`` rows as consecutive slices of at most ``step`` rows: the parts a chunk is worked in
    so that its bar moves.

    >>> bar_steps(2500)
    [slice(0, 1000, None), slice(1000, 2000, None), slice(2000, 2500, None)]
    """
    return [slice(s, min(s + step, n)) for s in range(0, n, step)]
