"""The compiled single-configuration entries and their binding (used by :mod:`kinematics.engine.single`
and by the batch path's batch of one, ``Kernel.fk`` / ``Kernel.jacobian`` in :mod:`kinematics.engine.plans`).

:func:`fk_one` and :func:`jacobian_one` take two packed tables (every argument costs the numba
call time) whose tail is the scratch the entry writes its frames to (the entries hold the GIL, so
one scratch serves every thread); :func:`_bind` makes the plain
function ``f(q, out=None)`` that calls one of them. This module reads a kernel (its ``_jint``,
``_jflt``, ``n``, ``poe.dof``, ``path_plan``) without importing :mod:`kinematics.engine.plans`.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numba.extending import overload

from ..errors import KinematicsError
# the batch kernels' private row kernels, JIT options and sine/cosine coefficients: a single entry repeats
# their arithmetic operation for operation so its answer equals the batch row bit for bit
from . import compiled as _c
from .compiled import _JIT, REVOLUTE, SINCOS_MAX_ARG, _jacobian_row


#: the single entries hold the GIL: a call takes well under a microsecond, less than releasing and
#: taking back the GIL would, and holding it lets every thread share one scratch (no thread can be
#: inside an entry while another is)
_JIT_GIL = {**_JIT, "nogil": False}
#: entries of ``itab``'s head: ``n, m, x, dof`` (:func:`_tables`)
_HEAD = 4


@nb.njit(inline="always", **_JIT_GIL)
def _row(t, at):
    """The four entries ``t[at: at + 4]`` (a row of a frame)."""
    return t[at], t[at + 1], t[at + 2], t[at + 3]


@nb.njit(inline="always", **_JIT_GIL)
def _frames_one(q, itab, ftab, fb):
    """The axis frames of the joints of the tables (parents first) for one configuration ``q``, into
    ``ftab[fb + 12 j: fb + 12 j + 12]`` (row ``4r + c``): the arithmetic of ``compiled._chunk_frames`` /
    ``_sincos_row`` / ``_joint_frames`` for a chunk of one, operation for operation (same bits), as
    scalar code on the flat tables of :func:`_tables` (no views: building one costs as much as a
    joint's arithmetic)."""
    n, m = itab[0], itab[1]
    jo = _HEAD + 3 * n
    for jj in range(m):
        j = itab[jo + jj]
        ji, jf, F = _HEAD + 3 * j, 14 * j, fb + 12 * j
        th = q[itab[ji]] * ftab[jf] + ftab[jf + 1]
        # sine and cosine: compiled._sincos_row
        k = np.rint(th * _c._TWO_OVER_PI)
        r = (th - k * _c._PIO2_1) - k * _c._PIO2_1T
        z = r * r
        sr = r + r * z * (_c._S6 + z * (_c._S5 + z * (_c._S4 + z * (_c._S3 + z * (_c._S2 + z * _c._S1)))))
        cr = 1.0 - 0.5 * z + z * z * (_c._C6 + z * (_c._C5 + z * (_c._C4 + z * (_c._C3 + z * (_c._C2 + z * _c._C1)))))
        qd = np.int64(k) & 3
        A = abs(qd - 2.0) - 1.0
        B = 1.0 - abs(qd - 1.0)
        s = A * sr + B * cr
        c = A * cr - B * sr
        if not abs(th) <= SINCOS_MAX_ARG:
            s = math.sin(th)
            c = math.cos(th)
        # the frame: compiled._joint_frames
        p = itab[ji + 2]
        revolute = itab[ji + 1] == REVOLUTE
        if p < 0:
            for r in range(3):
                x = ftab[jf + 2 + 4 * r]
                y = ftab[jf + 3 + 4 * r]
                zz = ftab[jf + 4 + 4 * r]
                t = ftab[jf + 5 + 4 * r]
                if revolute:
                    ftab[F + 4 * r] = c * x + s * y
                    ftab[F + 4 * r + 1] = c * y - s * x
                    ftab[F + 4 * r + 3] = t
                else:
                    ftab[F + 4 * r] = x
                    ftab[F + 4 * r + 1] = y
                    ftab[F + 4 * r + 3] = t + th * zz
                ftab[F + 4 * r + 2] = zz
            continue
        c00, c01, c02, c03 = ftab[jf + 2], ftab[jf + 3], ftab[jf + 4], ftab[jf + 5]
        c10, c11, c12, c13 = ftab[jf + 6], ftab[jf + 7], ftab[jf + 8], ftab[jf + 9]
        c20, c21, c22, c23 = ftab[jf + 10], ftab[jf + 11], ftab[jf + 12], ftab[jf + 13]
        P = fb + 12 * p
        for r in range(3):
            a0, a1, a2, p3 = _row(ftab, P + 4 * r)
            if revolute:
                x = a0 * c00 + a1 * c10 + a2 * c20
                y = a0 * c01 + a1 * c11 + a2 * c21
                ftab[F + 4 * r] = c * x + s * y
                ftab[F + 4 * r + 1] = c * y - s * x
                ftab[F + 4 * r + 2] = a0 * c02 + a1 * c12 + a2 * c22
                ftab[F + 4 * r + 3] = a0 * c03 + a1 * c13 + a2 * c23 + p3
            else:
                zz = a0 * c02 + a1 * c12 + a2 * c22
                ftab[F + 4 * r] = a0 * c00 + a1 * c10 + a2 * c20
                ftab[F + 4 * r + 1] = a0 * c01 + a1 * c11 + a2 * c21
                ftab[F + 4 * r + 2] = zz
                ftab[F + 4 * r + 3] = a0 * c03 + a1 * c13 + a2 * c23 + p3 + th * zz


@nb.njit(inline="always", **_JIT_GIL)
def _refused(q, dof):
    """``q`` is not a contiguous vector of ``dof`` values (the stride of a vector of one value or
    none does not matter, and numpy gives such vectors other strides)."""
    return q.shape[0] != dof or (dof > 1 and q.strides[0] != 8)


def _pose_of(out, k):  # pragma: no cover - compiled only (overloaded below)
    """In compiled code: pose ``k`` of ``out``, (L', 4, 4), or ``out`` itself when it is one (4, 4)."""


@overload(_pose_of, inline="always")
def _pose_of_overload(out, k):
    if out.ndim == 2:
        return lambda out, k: out
    return lambda out, k: out[k]


@nb.njit(**_JIT_GIL)
def fk_one(itab, ftab, out, q):
    """Poses of the links of a plan (as :func:`kinematics.engine.compiled.fk`) for one
    configuration ``q`` (dof,), into ``out`` (L', 4, 4) or (4, 4) for one link (C-contiguous).
    Tables as :func:`_tables` (``x`` unused, links: the plan's ``lj``, D: its (L', 4, 4) factors);
    the arithmetic of ``compiled._poses_row``, operation for operation. Refuses (returns True, writes
    nothing) a ``q`` that is not a contiguous vector of the tables' ``dof`` values."""
    if _refused(q, itab[3]):
        return True
    n, m = itab[0], itab[1]
    lo = _HEAD + 3 * n + m
    fb = ftab.shape[0] - 12 * n
    _frames_one(q, itab, ftab, fb)
    for k in range(itab.shape[0] - lo):
        o = _pose_of(out, k)
        j = itab[lo + k]
        d = 14 * n + 16 * k
        if j < 0:
            for e in range(16):
                o[e // 4, e % 4] = ftab[d + e]
            continue
        F = fb + 12 * j
        for r in range(3):
            f0, f1, f2, f3 = _row(ftab, F + 4 * r)
            o[r, 0] = f0 * ftab[d] + f1 * ftab[d + 4] + f2 * ftab[d + 8]
            o[r, 1] = f0 * ftab[d + 1] + f1 * ftab[d + 5] + f2 * ftab[d + 9]
            o[r, 2] = f0 * ftab[d + 2] + f1 * ftab[d + 6] + f2 * ftab[d + 10]
            o[r, 3] = f0 * ftab[d + 3] + f1 * ftab[d + 7] + f2 * ftab[d + 11] + f3
        o[3, 0] = 0.0
        o[3, 1] = 0.0
        o[3, 2] = 0.0
        o[3, 3] = 1.0
    return False


@nb.njit(**_JIT_GIL)
def jacobian_one(itab, ftab, out, q):
    """The Jacobian (6, dof) of a link (as :func:`kinematics.engine.compiled.jacobian`) for one
    configuration ``q`` (dof,), into ``out`` (zeroed here first). Tables as :func:`_tables` (``x``:
    the reference code, joints: the link's path, D: its (4, 4) factor); refuses ``q`` as :func:`fk_one`."""
    if _refused(q, itab[3]):
        return True
    for r in range(6):
        for c in range(out.shape[1]):
            out[r, c] = 0.0
    n, m = itab[0], itab[1]
    if m == 0:
        return False
    fb = ftab.shape[0] - 12 * n
    _frames_one(q, itab, ftab, fb)
    jint = itab[_HEAD: _HEAD + 3 * n].reshape(n, 3)
    path = itab[_HEAD + 3 * n: _HEAD + 3 * n + m]
    _jacobian_row(ftab[fb:].reshape(n, 12, 1), 0, path, jint, ftab[: 14 * n].reshape(n, 14),
                  ftab[14 * n: 14 * n + 16].reshape(4, 4), itab[2], out)
    return False


def _tables(kernel, joints, x: int, links, D: np.ndarray):
    """The packed tables of an entry: ``itab`` int64 ``[n, m, x, dof, jint (n x 3), joints (m), links]``
    (read-only) and ``ftab`` float64 ``[jflt (n x 14), D (... x 16), frames (n x 12)]``, whose tail
    is the scratch the entry writes its frames to (one argument each: every argument costs the call
    time)."""
    n = kernel.n
    itab = np.concatenate([np.array([n, len(joints), x, kernel.poe.dof], dtype=np.int64), kernel._jint.reshape(-1),
                           np.asarray(joints, dtype=np.int64), np.asarray(links, dtype=np.int64)])
    ftab = np.concatenate([kernel._jflt.reshape(-1), np.ascontiguousarray(D, dtype=np.float64).reshape(-1),
                           np.zeros(12 * n)])
    itab.setflags(write=False)
    return itab, ftab


def _coerce(q, dof: int) -> np.ndarray:
    q = np.ascontiguousarray(q, dtype=np.float64)
    if q.shape != (dof,):
        raise KinematicsError(f"q must be a vector of {dof} joint values, got shape {q.shape}")
    return q


def _compiled_entry(entry, itab, ftab, shape, dof):
    """The compiled ``entry`` for exactly the argument types :func:`_bind` passes, callable without
    numba's dispatcher (``overloads[signature].entry_point``: no typing of the four arguments on each
    call, a third of a single call's cost); the dispatcher itself if this numba has no such attribute."""
    args = (itab, ftab, np.empty(shape), np.zeros(dof))
    entry(*args)  # compiled, or loaded from the cache, for these types
    try:
        return entry.overloads[tuple(nb.typeof(a) for a in args)].entry_point
    except (AttributeError, KeyError):  # pragma: no cover - another numba's internals
        return entry


def _bind(entry, itab, ftab, shape, dof):
    """``f(q, out=None)`` calling the compiled ``entry`` on pre-bound tables (the hot path: no
    lookup beyond the ones below). The entry holds the GIL, so every thread shares the scratch tail
    of ``ftab``. A ``q`` that is a C-contiguous float64 vector of ``dof`` values and no ``out``
    take the compiled function directly (:func:`_compiled_entry`); other arguments are converted
    and checked first (``out``: an array of the result's shape), then go through numba's
    dispatcher, which checks their types too."""
    ndarray, f64, empty = np.ndarray, np.dtype(np.float64), np.empty
    direct = _compiled_entry(entry, itab, ftab, shape, dof)

    def call(q, out=None):
        if out is None and q.__class__ is ndarray and q.dtype is f64 and q.ndim == 1:
            out = empty(shape)
            if not direct(itab, ftab, out, q):  # (True: q is not a contiguous vector of dof values)
                return out
        q = _coerce(q, dof)
        if out is None:
            out = empty(shape)
        elif getattr(out, "shape", None) != shape:  # (the compiled entry writes the shape it was bound to)
            raise KinematicsError(f"out must be an array of shape {shape}, got {getattr(out, 'shape', type(out))}")
        entry(itab, ftab, out, q)
        return out

    return call


def bound_plan_fk(kernel, plan):
    """``f(q, out)`` of :func:`fk_one` for a plan of the batch kernel (the batch path's single
    configuration: ``Kernel.fk`` with one row); ``out`` (L', 4, 4)."""
    itab, ftab = _tables(kernel, plan.order, 0, plan.lj, plan.pose)
    return _bind(fk_one, itab, ftab, (plan.lj.shape[0], 4, 4), kernel.poe.dof)


def bound_path_jacobian(kernel, link_index: int, code: int):
    """``f(q, out)`` of :func:`jacobian_one` for link ``link_index`` and reference code ``code``
    (the batch path's single configuration: ``Kernel.jacobian`` with one row); ``out`` (6, dof)."""
    path, D = kernel.path_plan(link_index)
    dof = kernel.poe.dof
    itab, ftab = _tables(kernel, path, code, [], D)
    return _bind(jacobian_one, itab, ftab, (6, dof), dof)
