"""The two passes of reachability analysis, compiled (numba, cached on disk): a range of grid
steps per call, so that the caller checks its time budget between calls.

Each interval ``i`` carries rows ``cu[i, k] u + cx[i, k] x_i <= r[i, k]`` (``u`` the path
acceleration on the interval, ``x_i`` the squared path speed at its start); ``x_{i+1} = x_i + 2 ds_i u``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

_JIT = dict(cache=True, nogil=True, error_model="numpy")

#: relative slack when a vertex of a step's polygon is tested against its rows
FEASIBILITY_SLACK = 1e-12


@nb.njit(**_JIT)
def _max_x(al, be, rr):  # pragma: no cover - compiled
    """The largest x of the polygon ``{(x, y): al x + be y <= rr}`` (it holds the origin), over its vertices."""
    m = al.shape[0]
    best = 0.0
    for a in range(m):
        for b in range(a + 1, m):
            det = al[a] * be[b] - al[b] * be[a]
            if det == 0.0:
                continue
            x = (rr[a] * be[b] - rr[b] * be[a]) / det
            if not x > best:
                continue
            y = (al[a] * rr[b] - al[b] * rr[a]) / det
            ok = True
            for k in range(m):
                if al[k] * x + be[k] * y > rr[k] + FEASIBILITY_SLACK * (1.0 + abs(rr[k])):
                    ok = False
                    break
            if ok:
                best = x
    return best


@nb.njit(**_JIT)
def backward_steps(cu, cx, r, xmax, ds, X, start, stop):  # pragma: no cover - compiled
    """Fill ``X[i]`` for ``i = start - 1`` down to ``stop``: the largest ``x_i <= xmax[i]`` with a ``u`` that
    meets the rows of interval i and brings ``x_{i+1}`` into ``[0, X[i + 1]]``."""
    m = cu.shape[1]
    al = np.empty(m + 4)
    be = np.empty(m + 4)
    rr = np.empty(m + 4)
    for i in range(start - 1, stop - 1, -1):
        inv = 1.0 / (2.0 * ds[i])
        for k in range(m):  # in (x, y = x_{i+1}), u = (y - x) / (2 ds)
            al[k] = cx[i, k] - cu[i, k] * inv
            be[k] = cu[i, k] * inv
            rr[k] = r[i, k]
        al[m], be[m], rr[m] = 1.0, 0.0, xmax[i]
        al[m + 1], be[m + 1], rr[m + 1] = -1.0, 0.0, 0.0
        al[m + 2], be[m + 2], rr[m + 2] = 0.0, 1.0, X[i + 1]
        al[m + 3], be[m + 3], rr[m + 3] = 0.0, -1.0, 0.0
        X[i] = _max_x(al, be, rr)


@nb.njit(**_JIT)
def forward_steps(cu, cx, r, X, ds, x, u, start, stop):  # pragma: no cover - compiled
    """Fill ``u[i]`` and ``x[i + 1]`` for ``i`` in ``[start, stop)``: the largest ``u`` that meets the rows of
    interval i and keeps ``x_{i+1}`` in ``[0, X[i + 1]]``."""
    m = cu.shape[1]
    for i in range(start, stop):
        xi = x[i]
        ub = (X[i + 1] - xi) / (2.0 * ds[i])
        for k in range(m):
            if cu[i, k] > 0.0:
                v = (r[i, k] - cx[i, k] * xi) / cu[i, k]
                if v < ub:
                    ub = v
        xn = xi + 2.0 * ds[i] * ub
        xn = min(max(xn, 0.0), X[i + 1])
        x[i + 1] = xn
        u[i] = (xn - xi) / (2.0 * ds[i])
