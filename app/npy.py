"""NumPy ``.npy`` bodies: decoding requests safely (never unpickling), encoding names in headers."""

from __future__ import annotations

import io
from urllib.parse import quote

import numpy as np

from .errors import ProblemError

NPY_MAGIC = b"\x93NUMPY"
#: longest header value the service sends (clients such as httpx refuse much larger header blocks)
MAX_NAMES_HEADER = 8192


def decode_targets(body: bytes) -> np.ndarray:
    """IK targets from a ``.npy`` body: an ``(N, 4, 4)`` (or ``(4, 4)``) real array, as float64
    (rigidity and finiteness are checked by the library, naming the target)."""
    arr = _decode(body, "targets")
    if arr.shape[-2:] != (4, 4) or arr.ndim not in (2, 3):
        raise ProblemError(422, f"targets must be an (N, 4, 4) array of poses, got shape {arr.shape}",
                           slug="invalid-npy", field="body")
    return arr


def decode_q(body: bytes) -> np.ndarray:
    """A ``(N, dof)`` (or ``(dof,)``) real array from a ``.npy`` body, as float64.

    Refuses (4xx problem) anything but a plain numeric ``.npy`` file: another format (bad
    magic, ``.npz``, pickle), object / structured / complex / boolean / string dtypes,
    a truncated file, or more than two dimensions. Non-finite values are refused later
    with the joint named (:func:`kinematics.as_batch`).
    """
    arr = _decode(body, "joint values")
    if arr.ndim not in (1, 2):
        raise ProblemError(422, f"joint values must be an (N, dof) array, got shape {arr.shape}",
                           slug="invalid-npy", field="body")
    return arr


def _decode(body: bytes, what: str) -> np.ndarray:
    """A plain numeric array from a ``.npy`` body (no pickle, no .npz, no exotic dtype), as float64."""
    if not body.startswith(NPY_MAGIC):
        raise ProblemError(400, "the body is not a .npy file (bad magic); send np.save output with "
                           "Content-Type: application/x-npy", slug="invalid-npy", field="body")
    try:
        arr = np.load(io.BytesIO(body), allow_pickle=False)
    except ValueError as exc:
        if "pickle" in str(exc).lower() or "object" in str(exc).lower():
            raise ProblemError(422, "object arrays are refused (no pickle): send a float64 array",
                               slug="invalid-npy", field="body") from None
        raise ProblemError(400, f"malformed .npy body: {exc}", slug="invalid-npy", field="body") from None
    except Exception as exc:  # noqa: BLE001 - numpy raises assorted errors on hostile headers
        raise ProblemError(400, f"malformed .npy body: {type(exc).__name__}: {exc}", slug="invalid-npy",
                           field="body") from None
    if not isinstance(arr, np.ndarray):
        raise ProblemError(400, "the body is not a single .npy array", slug="invalid-npy", field="body")
    if arr.dtype.kind not in "fiu" or arr.dtype.fields is not None:
        raise ProblemError(422, f"{what} must be real numbers (float64), got dtype {arr.dtype}",
                           slug="invalid-npy", field="body")
    return np.ascontiguousarray(arr, dtype=np.float64)


def names_header(names) -> str | None:
    """Comma-separated names, each percent-encoded (commas and non-ASCII are escaped); None if too long."""
    value = ",".join(quote(str(n), safe="") for n in names)
    return value if len(value) <= MAX_NAMES_HEADER else None
