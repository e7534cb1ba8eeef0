"""Result arrays: cache-line aligned, and large ones recycled instead of faulted in afresh.

A large FK answer costs more to *allocate* than to compute. glibc serves allocations above
its mmap threshold (at most 32 MiB) with a fresh ``mmap`` each time and unmaps them on
free, so every call pays the kernel for zeroing new pages before the kernel can write its
poses: for a large tree and batch (talos_reduced, 10,000 configurations: 77 MiB) that costs
more than the FK itself (``bench/RESULTS.md``).
Below 32 MiB glibc keeps freed memory in its heap and hands it out again.

:func:`result_array` does the same for the large ones: when the last reference to a result
is gone, its buffer goes back to a small pool (at most ``POOL_BYTES`` in all, exact sizes),
and the next result of that size reuses it, already faulted in. Arrays are ordinary
C-contiguous float64 ndarrays; their ``base`` is a :class:`_Lease` whose finalizer returns
the buffer. A view of the result keeps the result (its base) alive, and so the lease: the
buffer is reused only when the result and every view of it are gone.
"""

from __future__ import annotations

import math
import threading
import weakref

import numpy as np

#: Bytes of a cache line: results start on such a boundary.
CACHE_LINE = 64
#: Arrays with fewer elements than this are not aligned beyond numpy's 16 bytes.
ALIGN_MIN_ELEMENTS = 4096
#: Results of at least this many bytes are pooled (glibc recycles the smaller ones itself).
POOL_MIN_BYTES = 32 << 20
#: Most bytes of free buffers the pool keeps; a buffer returned beyond that is freed.
POOL_BYTES = 128 << 20


def aligned_empty(shape: tuple[int, ...], align: int = CACHE_LINE) -> np.ndarray:
    """An uninitialised C-contiguous float64 array whose data starts on an ``align``-byte boundary.

    numpy's allocations are 16-byte aligned; a 4x4 pose (128 bytes) then straddles three cache
    lines instead of two, and the per-link writes of the kernels touch each boundary line twice.
    """
    n = math.prod(shape)
    if n < ALIGN_MIN_ELEMENTS:  # small: the extra call costs more than it saves
        return np.empty(shape)
    raw = np.empty(n + align // 8)
    start = (-raw.ctypes.data % align) // 8
    return raw[start:start + n].reshape(shape)


class _Lease:
    """Owner of a pooled buffer while a result (or any view of it) is alive."""

    __slots__ = ("__array_interface__", "__weakref__")

    def __init__(self, data: np.ndarray, shape: tuple[int, ...]):
        self.__array_interface__ = {"shape": shape, "typestr": "<f8", "data": (data.ctypes.data, False), "version": 3}


class _Pool:
    """Free buffers by element count, at most ``limit`` bytes in all (thread-safe)."""

    def __init__(self, limit: int):
        self.limit = limit
        self.held = 0
        self.free: dict[int, list[np.ndarray]] = {}
        # re-entrant: a lease's finalizer (give_back) may run inside take() or give_back() when
        # an allocation there sets off the cyclic garbage collector
        self.lock = threading.RLock()
        self.reused = 0  # statistics (tests)
        self.allocated = 0

    def take(self, n: int) -> np.ndarray:
        with self.lock:
            stack = self.free.get(n)
            if stack:
                self.held -= stack[-1].nbytes
                self.reused += 1
                return stack.pop()
            self.allocated += 1
        return aligned_empty((n,))

    def give_back(self, data: np.ndarray) -> None:
        with self.lock:
            if self.held + data.nbytes <= self.limit:
                self.free.setdefault(data.size, []).append(data)
                self.held += data.nbytes

    def clear(self) -> None:
        with self.lock:
            self.free.clear()
            self.held = 0


POOL = _Pool(POOL_BYTES)


def result_array(shape: tuple[int, ...]) -> np.ndarray:
    """An uninitialised C-contiguous float64 array for a result: aligned to a cache line, and
    from the pool of recycled buffers when it is at least ``POOL_MIN_BYTES``."""
    n = math.prod(shape)
    if 8 * n < POOL_MIN_BYTES:
        return aligned_empty(shape)
    data = POOL.take(n)
    lease = _Lease(data, tuple(shape))
    weakref.finalize(lease, POOL.give_back, data)  # keeps `data` alive until the lease is gone
    return np.asarray(lease)
