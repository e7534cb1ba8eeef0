"""Progress bars for long CLI work: shown on a terminal, silent when piped."""

from __future__ import annotations

import sys

from tqdm import tqdm


def progress(iterable=None, **kwargs):
    """A tqdm bar on stderr when stderr is a terminal; otherwise the bare iterable."""
    kwargs.setdefault("file", sys.stderr)
    kwargs.setdefault("disable", not sys.stderr.isatty())
    kwargs.setdefault("leave", False)
    return tqdm(iterable, **kwargs)
