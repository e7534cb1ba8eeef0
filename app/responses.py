"""Response classes: fast JSON (orjson, numpy arrays serialised natively), problem details, .npy.

FastAPI deprecated its own ``ORJSONResponse`` in favour of serialising response models with
pydantic. The service does both: small answers (model info, listings) go through their
pydantic response models; the large ones (batch FK and Jacobians) are built from numpy
arrays and serialised here by orjson directly, without a per-element validation pass.
"""

from __future__ import annotations

import io
import time
from typing import Any

import numpy as np
import orjson
from fastapi.responses import JSONResponse, Response

from kinematics.usecases import check_cancelled

NPY_MEDIA_TYPE = "application/x-npy"
NPZ_MEDIA_TYPE = "application/x-npz"
PROBLEM_MEDIA_TYPE = "application/problem+json"

_ORJSON_OPTIONS = orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS


#: lists and arrays longer than this are encoded a slice at a time (the same bytes): one orjson call
#: holds the GIL from start to end (~0.2 s for the JSON of 100,000 FK poses, ~2 s for a million),
#: and between two slices the event loop and the other threads get it
CHUNK_ITEMS = 2048


def dumps(content: Any) -> bytes:
    """orjson bytes of ``content``; numpy arrays and scalars included (non-finite floats -> null)."""
    return b"".join(dump_parts(content))


def dump_parts(content: Any) -> list[bytes]:
    """:func:`dumps` as a list of parts: one for a small answer; for a large one, long lists and
    arrays (in the answer or in its dicts, 3 levels deep) a slice of :data:`CHUNK_ITEMS` items per
    part, so that no single step holds the GIL for long (one orjson call, or one join of the
    whole answer, does: ~0.2 s and ~0.1 s for the JSON of 100,000 FK poses of three links)."""
    if not _large(content, 3):
        return [orjson.dumps(content, option=_ORJSON_OPTIONS, default=_default)]
    out: list[bytes] = []
    _parts(content, out)
    return out


def _large(value: Any, depth: int) -> bool:
    if isinstance(value, (list, np.ndarray)):
        return len(value) > CHUNK_ITEMS
    if isinstance(value, dict) and depth > 0:
        return any(_large(v, depth - 1) for v in value.values())
    return False


def _parts(value: Any, out: list[bytes]) -> None:
    if isinstance(value, dict) and _large(value, 3):
        sep = b"{"
        for k, v in value.items():
            key = orjson.dumps({k: 0}, option=_ORJSON_OPTIONS)[1:-2]  # b'"k":' (keys as orjson writes them)
            out.append(sep + key)
            _parts(v, out)
            sep = b","
        out.append(b"}")
    elif isinstance(value, (list, np.ndarray)) and len(value) > CHUNK_ITEMS:
        sep = b"["
        for a in range(0, len(value), CHUNK_ITEMS):
            out.append(sep + orjson.dumps(value[a:a + CHUNK_ITEMS], option=_ORJSON_OPTIONS, default=_default)[1:-1])
            sep = b","
            time.sleep(0)  # hand the GIL over: a thread waiting for it (the event loop) goes first
            check_cancelled()  # a large answer is built under the request's budget, stopped with its client
        out.append(b"]")
    else:
        out.append(orjson.dumps(value, option=_ORJSON_OPTIONS, default=_default))


def _default(obj: Any):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):  # non-contiguous or non-native arrays
        return np.ascontiguousarray(obj, dtype=float).tolist() if obj.dtype.kind == "f" else obj.tolist()
    raise TypeError(f"cannot serialise {type(obj).__name__}")


class FastJSONResponse(JSONResponse):
    """JSON rendered by orjson (numpy arrays serialised natively). A large answer is sent as the
    parts of :func:`dump_parts`, one body message each (never joined into one buffer); ``body`` is
    then empty and ``content-length`` the sum of the parts."""

    _parts: list[bytes] | None = None

    def render(self, content: Any) -> bytes:
        parts = dump_parts(content)
        if len(parts) == 1:
            return parts[0]
        self._parts = parts
        return b""

    def init_headers(self, headers=None) -> None:
        super().init_headers(headers)
        if self._parts is not None:
            size = str(sum(len(p) for p in self._parts)).encode()
            self.raw_headers = [(k, size if k == b"content-length" else v) for k, v in self.raw_headers]

    async def __call__(self, scope, receive, send) -> None:
        if self._parts is None:
            return await super().__call__(scope, receive, send)
        await send({"type": "http.response.start", "status": self.status_code, "headers": self.raw_headers})
        last = len(self._parts) - 1
        for i, part in enumerate(self._parts):
            await send({"type": "http.response.body", "body": part, "more_body": i < last})
        if self.background is not None:
            await self.background()


class SmallJSONResponse(FastJSONResponse):
    """A JSON answer its route knows to be small (no list or array over :data:`CHUNK_ITEMS` items, a
    few configurations): one orjson call, the bytes :func:`dump_parts` gives such an answer, without
    its walk through the answer looking for long lists (a third of the encoding time of one
    configuration's FK answer)."""

    def render(self, content: Any) -> bytes:
        return orjson.dumps(content, option=_ORJSON_OPTIONS, default=_default)


class ProblemResponse(FastJSONResponse):
    """An RFC 9457 problem-details answer."""

    media_type = PROBLEM_MEDIA_TYPE


class NpyResponse(Response):
    """A NumPy ``.npy`` array (float64, C order); never pickled.

    Sent without copying the array: the ``.npy`` header (format 1.0, padded to 64 bytes by
    :mod:`numpy.lib.format`) goes out as a first body message and the array's own buffer
    (a ``memoryview``) as the second. ``body`` holds the header only; ``content_length``
    is the size of the whole file.
    """

    media_type = NPY_MEDIA_TYPE

    def __init__(self, array: np.ndarray, headers: dict[str, str] | None = None, status_code: int = 200):
        self.array = np.ascontiguousarray(array, dtype=np.float64)
        self.body = npy_header(self.array)
        self.content_length = len(self.body) + self.array.nbytes
        self.status_code = status_code
        self.background = None
        self.init_headers({**(headers or {}), "content-length": str(self.content_length)})

    async def __call__(self, scope, receive, send) -> None:
        await send({"type": "http.response.start", "status": self.status_code, "headers": self.raw_headers})
        await send({"type": "http.response.body", "body": self.body, "more_body": True})
        await send({"type": "http.response.body", "body": memoryview(self.array).cast("B")})


class NpzResponse(Response):
    """Named arrays as an uncompressed NumPy ``.npz`` archive (``np.savez``; never pickled)."""

    media_type = NPZ_MEDIA_TYPE

    def __init__(self, arrays: dict[str, np.ndarray], headers: dict[str, str] | None = None, status_code: int = 200):
        buf = io.BytesIO()
        # (np.ascontiguousarray would turn a scalar into shape (1,): scalars stay 0-d)
        np.savez(buf, **{name: np.ascontiguousarray(a) if np.ndim(a) else np.asarray(a) for name, a in arrays.items()})
        super().__init__(buf.getvalue(), status_code=status_code, headers=headers)


def npy_header(array: np.ndarray) -> bytes:
    """The ``.npy`` (format 1.0) header of a C-contiguous ``array``: ``header + array.tobytes()`` is
    exactly what ``np.save(f, array)`` writes."""
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, np.lib.format.header_data_from_array_1_0(array))
    return buf.getvalue()
