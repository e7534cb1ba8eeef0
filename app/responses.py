"""Response classes: fast JSON (orjson, numpy arrays serialised natively), problem details, .npy.

FastAPI deprecated its own ``ORJSONResponse`` in favour of serialising response models with
pydantic. The service does both: small answers (model info, listings) go through their
pydantic response models; the large ones (batch FK and Jacobians) are built from numpy
arrays and serialised here by orjson directly, without a per-element validation pass.
"""

from __future__ import annotations

import io
from typing import Any

import numpy as np
import orjson
from fastapi.responses import JSONResponse, Response

NPY_MEDIA_TYPE = "application/x-npy"
PROBLEM_MEDIA_TYPE = "application/problem+json"

_ORJSON_OPTIONS = orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS


def dumps(content: Any) -> bytes:
    """orjson bytes of ``content``; numpy arrays and scalars included (non-finite floats -> null)."""
    return orjson.dumps(content, option=_ORJSON_OPTIONS, default=_default)


def _default(obj: Any):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):  # non-contiguous or non-native arrays
        return np.ascontiguousarray(obj, dtype=float).tolist() if obj.dtype.kind == "f" else obj.tolist()
    raise TypeError(f"cannot serialise {type(obj).__name__}")


class FastJSONResponse(JSONResponse):
    """JSON rendered by orjson (numpy arrays serialised natively)."""

    def render(self, content: Any) -> bytes:
        return dumps(content)


class ProblemResponse(FastJSONResponse):
    """An RFC 9457 problem-details answer."""

    media_type = PROBLEM_MEDIA_TYPE


class NpyResponse(Response):
    """A NumPy ``.npy`` array (float64, C order); never pickled."""

    media_type = NPY_MEDIA_TYPE

    def __init__(self, array: np.ndarray, headers: dict[str, str] | None = None, status_code: int = 200):
        buf = io.BytesIO()
        np.save(buf, np.ascontiguousarray(array, dtype=np.float64), allow_pickle=False)
        super().__init__(content=buf.getvalue(), status_code=status_code, headers=headers, media_type=self.media_type)
