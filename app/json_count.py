"""Counting the items of a JSON body's top-level arrays without decoding it.

A JSON decode builds a Python object per number (a list of 10^5 IK targets, 26 MB of JSON, took
gigabytes as pydantic's objects): a body whose batch is over its limit is refused from its count
before that. :func:`top_level_counts` reads the raw bytes :data:`CHUNK_BYTES` at a time with numpy
(its memory does not grow with the body): the structure (brackets, braces, commas, colons) outside
strings, escaped quotes included, and the nesting depth. It counts the items of each wanted key's
array in the root object (its commas at depth 2, plus one) and tells how many containers open at
its first item (0: numbers, 1: vectors, 2: matrices or objects), which tells one vector from a
batch. A body that is not such an object, or malformed, gives what it could count; the decode that
follows says what is wrong with it.

>>> top_level_counts(b'{"q": [[1, 2], [3, 4], [5, 6]], "links": ["a,b", "c]"], "x": {"q": [1]}}', ("q", "links"))
{'q': (3, 1), 'links': (2, 0)}
>>> top_level_counts(rb'{"note": "a \\" [ ,", "q": [0.5, 1], "target": {"position": [0, 0, 1]}}', ("q", "target"))
{'q': (2, 0)}
"""

from __future__ import annotations

import json
import re

import numpy as np

#: bytes scanned at a time (the scan's memory: a few arrays of this many small integers)
CHUNK_BYTES = 1 << 20

_QUOTE, _BACKSLASH, _COMMA, _COLON = ord('"'), ord("\\"), ord(","), ord(":")
_DELTA = np.zeros(256, dtype=np.int32)
_DELTA[[ord("["), ord("{")]] = 1
_DELTA[[ord("]"), ord("}")]] = -1
_WHITESPACE = b" \t\r\n"
#: a JSON string ending where a key's colon follows it (keys longer than this are not looked at)
_SPACE = re.compile(rb"[ \t\r\n]*")
_KEY = re.compile(rb'"((?:[^"\\]|\\.){0,256})"[ \t\r\n]*\Z', re.DOTALL)


def _key_before(body: bytes, colon: int) -> str | None:
    """The key whose ``:`` is at ``colon`` (None if it is not a short plain string)."""
    m = _KEY.search(body, max(0, colon - 600), colon)
    if m is None:
        return None
    try:
        key = json.loads(m.group(0))
    except ValueError:
        return None
    return key if isinstance(key, str) else None


def _item_depth(body: bytes, at: int) -> int:
    """How many containers open at the first item of the array opened at ``at`` (0: a scalar; an
    object counts as two: a pose or a measurement is a container of values)."""
    depth = 0
    for byte in body[at + 1: at + 64]:
        if byte in _WHITESPACE:
            continue
        if byte == ord("{"):
            return depth + 2
        if byte == ord("["):
            depth += 1
            continue
        return depth
    return depth


def top_level_counts(body: bytes, keys) -> dict[str, tuple[int, int]]:
    """``{key: (items, depth)}`` of each of ``keys`` whose value in the root object is an array: its
    number of items and how many containers open at its first item. Memory bounded by
    :data:`CHUNK_BYTES`, whatever the body's size."""
    keys = set(keys)
    depth, in_string, slashes = 0, 0, 0  # carried from a chunk to the next
    colons: list[int] = []  # the root object's colons (one per key)
    opens: list[int] = []  # containers opening at depth 2: the root's values
    commas = np.zeros(0, dtype=np.int64)  # per value of `opens`, its commas at depth 2
    for base in range(0, len(body), CHUNK_BYTES):
        b = np.frombuffer(body, dtype=np.uint8, count=min(CHUNK_BYTES, len(body) - base), offset=base)
        quotes = np.flatnonzero(b == _QUOTE)
        if quotes.size:  # a quote after an odd run of backslashes is escaped
            plain = np.flatnonzero(b != _BACKSLASH)
            last = np.searchsorted(plain, quotes) - 1  # the last byte before each quote that is not one
            run = quotes - np.where(last >= 0, plain[np.maximum(last, 0)] + 1, -slashes)
            quotes = quotes[run % 2 == 0]
        toggles = np.zeros(b.shape[0], dtype=np.int32)
        toggles[quotes] = 1
        # inside a string (its quotes included): an odd number of quotes up to here, or a closing quote
        inside = ((np.cumsum(toggles, dtype=np.int32) + in_string) & 1).astype(bool)
        inside[quotes] = True
        delta = np.where(inside, 0, _DELTA[b])
        levels = np.cumsum(delta, dtype=np.int32) + depth  # the depth after each byte
        if levels.size and int(levels.min()) < 0:
            break  # more closed than opened: not JSON (the decode says so)
        outside = ~inside
        colons += (base + np.flatnonzero(outside & (b == _COLON) & (levels == 1))).tolist()
        new = np.flatnonzero((delta == 1) & (levels == 2))
        opens += (base + new).tolist()
        commas = np.concatenate([commas, np.zeros(new.size, dtype=np.int64)])
        at = np.flatnonzero(outside & (b == _COMMA) & (levels == 2))
        if at.size and opens:  # each comma belongs to the root's value opened last before it
            owner = np.searchsorted(np.asarray(opens, dtype=np.int64), base + at, side="right") - 1
            owner = owner[owner >= 0]
            commas += np.bincount(owner, minlength=commas.size)[:commas.size]
        depth, in_string = int(levels[-1]), (in_string + int(quotes.size)) & 1
        run = b.shape[0] - 1 - int(np.flatnonzero(b != _BACKSLASH)[-1]) if (b != _BACKSLASH).any() else -1
        slashes = slashes + b.shape[0] if run < 0 else run
    out: dict[str, tuple[int, int]] = {}
    index = {position: i for i, position in enumerate(opens)}
    for colon in colons:
        key = _key_before(body, colon)
        if key not in keys:
            continue
        start = _SPACE.match(body, colon + 1).end()
        if start not in index or body[start:start + 1] != b"[":  # not an array (an object, a number, a string)
            continue
        empty = body[start + 1: start + 64].lstrip(_WHITESPACE)[:1] == b"]"
        out[key] = (0 if empty else int(commas[index[start]]) + 1, _item_depth(body, start))
    return out
