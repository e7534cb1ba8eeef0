"""Compiled (numba) workspace sampling: for a batch of configurations, the position of one frame
(a link, or a point / tool on it) and the manipulability there, in one pass per chunk.

The frames come from :func:`kinematics.engine.compiled._chunk_frames` (the FK kernel's), the
position is the origin of ``F_last · D`` and the Jacobian the ``local_world_aligned`` one of the
Jacobian kernel (origin velocity and angular velocity, world axes), over the q columns of the
joints on the path (a mimic joint's column added to its leader's, times its multiplier). With
``rows`` = 6 (``pose``: the whole Jacobian) or 3 (``position``: its linear rows) and ``k`` columns,

    manipulability = sqrt(det(J^T J))   (k <= rows)    or    sqrt(det(J J^T))   (k > rows),

the product of the ``min(rows, k)`` singular values of ``J`` (Yoshikawa's measure; for an arm with
fewer joints than rows, of its k singular values, as :func:`kinematics.algorithms.measures.conditioning`).
It is taken per configuration as the product of the diagonal of R in a Householder QR of ``J``
(or ``J^T``), without the singular values themselves, and without squaring the condition number
as the determinant of ``J^T J`` would (a singular Jacobian gives ~1e-17, not ~1e-9).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

# the FK kernel's chunk walk and scratch buffers, private to the engine: sampling runs the same frames
from .compiled import J_KIND, J_MULT, J_QINDEX, REVOLUTE, _chunk_frames, _scratch

_JIT = dict(cache=True, nogil=True, boundscheck=False, error_model="numpy")

#: measures of the kernel: none, the 6 x k Jacobian, its 3 x k position rows
MEASURE_NONE, MEASURE_POSE, MEASURE_POSITION = 0, 1, 2


@nb.njit(**_JIT)
def _product_of_r_diagonal(A, r, c):
    """|R_00 ... R_(c-1)(c-1)| of the QR factorisation of the leading r x c block of A (r >= c;
    overwritten), by Householder reflections: the product of the c singular values of that block
    (``sqrt(det(A^T A))``), to rounding of the size of A's entries, even when it is singular."""
    prod = 1.0
    for j in range(c):
        norm2 = 0.0
        for e in range(j, r):
            norm2 += A[e, j] * A[e, j]
        if norm2 == 0.0:
            return 0.0
        norm = math.sqrt(norm2)
        alpha = -norm if A[j, j] > 0.0 else norm
        prod *= norm
        # v = A[j:, j] - alpha e_j; reflect the remaining columns: A <- A - 2 v (v . A) / (v . v)
        v0 = A[j, j] - alpha
        vv = norm2 - A[j, j] * A[j, j] + v0 * v0
        if vv == 0.0:
            continue
        for col in range(j + 1, c):
            d = v0 * A[j, col]
            for e in range(j + 1, r):
                d += A[e, j] * A[e, col]
            f = 2.0 * d / vv
            A[j, col] -= f * v0
            for e in range(j + 1, r):
                A[e, col] -= f * A[e, j]
    return prod


@nb.njit(**_JIT)
def sample(Q, jint, jflt, path, colpos, k, D, measure, P, M, chunk):
    """Positions ``P`` (N, 3) of the frame ``F_last · D`` and manipulability ``M`` (N,) for q (N, dof).

    path: the moving joints from the root to the link, root first (k >= 1 q columns among them);
    colpos: (dof,) position of each q column among the path's columns (-1: not on the path);
    measure: MEASURE_NONE (M untouched), MEASURE_POSE or MEASURE_POSITION.
    """
    N = Q.shape[0]
    npath = path.shape[0]
    F, W = _scratch(jint.shape[0], chunk)
    last = path[npath - 1]
    rows = 6 if measure == MEASURE_POSE else 3
    J = np.zeros((6, max(k, 1)))
    A = np.zeros((max(rows, k), max(rows, k)))
    for a in range(0, N, chunk):
        m = min(chunk, N - a)
        _chunk_frames(Q, a, m, path, jint, jflt, F, W)
        Fl = F[last]
        for i in range(m):
            ox = Fl[0, i] * D[0, 3] + Fl[1, i] * D[1, 3] + Fl[2, i] * D[2, 3] + Fl[3, i]
            oy = Fl[4, i] * D[0, 3] + Fl[5, i] * D[1, 3] + Fl[6, i] * D[2, 3] + Fl[7, i]
            oz = Fl[8, i] * D[0, 3] + Fl[9, i] * D[1, 3] + Fl[10, i] * D[2, 3] + Fl[11, i]
            P[a + i, 0] = ox
            P[a + i, 1] = oy
            P[a + i, 2] = oz
            if measure == 0:
                continue
            J[:, :] = 0.0
            for jj in range(npath):
                j = path[jj]
                Fj = F[j]
                wx, wy, wz = Fj[2, i], Fj[6, i], Fj[10, i]
                if jint[j, J_KIND] == REVOLUTE:
                    dx, dy, dz = ox - Fj[3, i], oy - Fj[7, i], oz - Fj[11, i]
                    vx = wy * dz - wz * dy
                    vy = wz * dx - wx * dz
                    vz = wx * dy - wy * dx
                    ax, ay, az = wx, wy, wz
                else:
                    vx, vy, vz = wx, wy, wz
                    ax = ay = az = 0.0
                c = colpos[jint[j, J_QINDEX]]
                mu = jflt[j, J_MULT]
                J[0, c] += mu * vx
                J[1, c] += mu * vy
                J[2, c] += mu * vz
                J[3, c] += mu * ax
                J[4, c] += mu * ay
                J[5, c] += mu * az
            if k <= rows:  # the k singular values of J (rows x k)
                for r in range(rows):
                    for c in range(k):
                        A[r, c] = J[r, c]
                M[a + i] = _product_of_r_diagonal(A, rows, k)
            else:  # the rows singular values of J: those of J^T (k x rows)
                for r in range(k):
                    for c in range(rows):
                        A[r, c] = J[c, r]
                M[a + i] = _product_of_r_diagonal(A, k, rows)
    return P


def sample_frame(kernel, Q: np.ndarray, link_index: int, tool: np.ndarray | None = None, measure: int = MEASURE_POSE,
                 P: np.ndarray | None = None, M: np.ndarray | None = None,
                 chunk: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """``(P (N, 3), M (N,))``: the origin of link ``link_index`` (times ``tool``, ``T_link_tool``) and
    the manipulability there, for q (N, dof), with the tables of a
    :class:`~kinematics.engine.plans.Kernel`. ``P`` / ``M`` may be given to write into (views of
    a larger result). A link no joint moves sits at its home pose with manipulability 1 (the
    empty product of singular values)."""
    from .plans import with_tool

    N = Q.shape[0]
    P = np.empty((N, 3)) if P is None else P
    M = np.empty(N) if M is None else M
    path, D = kernel.path_plan(link_index)
    D = with_tool(D, tool)
    if len(path) == 0:
        home = kernel.poe.M[link_index] if tool is None else kernel.poe.M[link_index] @ tool
        P[:] = home[:3, 3]
        M[:] = 1.0
        return P, M
    cols = kernel.path_columns(link_index)
    colpos = np.full(Q.shape[1], -1, dtype=np.int64)
    colpos[cols] = np.arange(len(cols))
    if N:
        sample(np.ascontiguousarray(Q, dtype=np.float64), kernel._jint, kernel._jflt, path, colpos, len(cols),
               np.ascontiguousarray(D), measure, P, M, max(1, min(chunk, N)))
    return P, M
