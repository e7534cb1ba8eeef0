"""The compiled single-configuration entries and their binding (used by :mod:`kinematics.engine.single`
and by the batch path's batch of one, ``Kernel.fk`` / ``Kernel.jacobian`` in :mod:`kinematics.engine.plans`).

:func:`fk_one` and :func:`jacobian_one` take two packed tables (every argument costs the numba
dispatcher time) whose tail is a per-thread scratch buffer; :func:`_bind` makes the plain
function ``f(q, out=None)`` that calls one of them. This module reads a kernel (its ``_jint``,
``_jflt``, ``n``, ``poe.dof``, ``path_plan``) without importing :mod:`kinematics.engine.plans`.
"""

from __future__ import annotations

import math
import threading

import numba as nb
import numpy as np

from ..errors import KinematicsError
# the batch kernels' private row kernels, JIT options and sine/cosine coefficients: a single entry repeats
# their arithmetic operation for operation so its answer equals the batch row bit for bit
from . import compiled as _c
from .compiled import _JIT, REVOLUTE, SINCOS_MAX_ARG, _jacobian_row, _poses_row


@nb.njit(**_JIT)
def _unpack(itab, ftab, q):
    """The packed tables: ``itab`` int64 ``[n, m, x, jint (n x 3), joints (m), links]`` and ``ftab``
    float64 ``[jflt (n x 14), D (... x 16), scratch (15 n + dof)]`` (one argument each: every
    argument costs the dispatcher time)."""
    n, m = itab[0], itab[1]
    jint = itab[3: 3 + 3 * n].reshape(n, 3)
    joints = itab[3 + 3 * n: 3 + 3 * n + m]
    links = itab[3 + 3 * n + m:]
    dof = q.shape[0]
    size = ftab.shape[0]
    jflt = ftab[: 14 * n].reshape(n, 14)
    D = ftab[14 * n: size - 15 * n - dof]
    base = size - 15 * n - dof
    F = ftab[base: base + 12 * n].reshape(n, 12, 1)
    W = ftab[base + 12 * n: base + 15 * n].reshape(3, n, 1)
    Q = ftab[base + 15 * n:].reshape(1, dof)
    for c in range(dof):
        Q[0, c] = q[c]
    return jint, joints, links, jflt, D, F, W, Q


@nb.njit(**_JIT)
def _frames_one(q, joints, jint, jflt, F):
    """The axis frames ``F[j, :, 0]`` of ``joints`` (parents first) for one configuration: the
    arithmetic of ``compiled._chunk_frames`` / ``_sincos_row`` / ``_joint_frames`` for a chunk of
    one, operation for operation (same bits), as scalar code without the chunk's row views."""
    for jj in range(joints.shape[0]):
        j = joints[jj]
        th = q[jint[j, 0]] * jflt[j, 0] + jflt[j, 1]
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
        p = jint[j, 2]
        revolute = jint[j, 1] == REVOLUTE
        if p < 0:
            for r in range(3):
                x = jflt[j, 2 + 4 * r]
                y = jflt[j, 2 + 4 * r + 1]
                zz = jflt[j, 2 + 4 * r + 2]
                t = jflt[j, 2 + 4 * r + 3]
                if revolute:
                    F[j, 4 * r, 0] = c * x + s * y
                    F[j, 4 * r + 1, 0] = c * y - s * x
                    F[j, 4 * r + 3, 0] = t
                else:
                    F[j, 4 * r, 0] = x
                    F[j, 4 * r + 1, 0] = y
                    F[j, 4 * r + 3, 0] = t + th * zz
                F[j, 4 * r + 2, 0] = zz
            continue
        c00, c01, c02, c03 = jflt[j, 2], jflt[j, 3], jflt[j, 4], jflt[j, 5]
        c10, c11, c12, c13 = jflt[j, 6], jflt[j, 7], jflt[j, 8], jflt[j, 9]
        c20, c21, c22, c23 = jflt[j, 10], jflt[j, 11], jflt[j, 12], jflt[j, 13]
        for r in range(3):
            a0 = F[p, 4 * r, 0]
            a1 = F[p, 4 * r + 1, 0]
            a2 = F[p, 4 * r + 2, 0]
            p3 = F[p, 4 * r + 3, 0]
            if revolute:
                x = a0 * c00 + a1 * c10 + a2 * c20
                y = a0 * c01 + a1 * c11 + a2 * c21
                F[j, 4 * r, 0] = c * x + s * y
                F[j, 4 * r + 1, 0] = c * y - s * x
                F[j, 4 * r + 2, 0] = a0 * c02 + a1 * c12 + a2 * c22
                F[j, 4 * r + 3, 0] = a0 * c03 + a1 * c13 + a2 * c23 + p3
            else:
                zz = a0 * c02 + a1 * c12 + a2 * c22
                F[j, 4 * r, 0] = a0 * c00 + a1 * c10 + a2 * c20
                F[j, 4 * r + 1, 0] = a0 * c01 + a1 * c11 + a2 * c21
                F[j, 4 * r + 2, 0] = zz
                F[j, 4 * r + 3, 0] = a0 * c03 + a1 * c13 + a2 * c23 + p3 + th * zz


@nb.njit(**_JIT)
def fk_one(itab, ftab, out, q):
    """Poses of the links of a plan (as :func:`kinematics.engine.compiled.fk`) for one
    configuration ``q`` (dof,), into ``out`` (L', 4, 4) or (4, 4) for one link (C-contiguous).
    Tables as :func:`_unpack` (``x`` unused, links: the plan's ``lj``, D: its (L', 4, 4) factors)."""
    jint, order, lj, jflt, D, F, W, Q = _unpack(itab, ftab, q)
    _frames_one(q, order, jint, jflt, F)
    _poses_row(F, 0, lj, D.reshape(lj.shape[0], 4, 4), out.reshape(lj.shape[0], 16))


@nb.njit(**_JIT)
def jacobian_one(itab, ftab, out, q):
    """The Jacobian (6, dof) of a link (as :func:`kinematics.engine.compiled.jacobian`) for one
    configuration ``q`` (dof,), into ``out`` (zeroed here first). Tables as :func:`_unpack` (``x``:
    the reference code, joints: the link's path, D: its (4, 4) factor)."""
    jint, path, _, jflt, D, F, W, Q = _unpack(itab, ftab, q)
    for r in range(6):
        for c in range(out.shape[1]):
            out[r, c] = 0.0
    if path.shape[0] == 0:
        return
    _frames_one(q, path, jint, jflt, F)
    _jacobian_row(F, 0, path, jint, jflt, D.reshape(4, 4), itab[2], out)


def _tables(kernel, joints, x: int, links, D: np.ndarray, dof: int):
    n = kernel.n
    itab = np.concatenate([np.array([n, len(joints), x], dtype=np.int64), kernel._jint.reshape(-1),
                           np.asarray(joints, dtype=np.int64), np.asarray(links, dtype=np.int64)])
    ftab = np.concatenate([kernel._jflt.reshape(-1), np.ascontiguousarray(D, dtype=np.float64).reshape(-1),
                           np.zeros(15 * n + dof)])
    itab.setflags(write=False)
    return itab, ftab


def _coerce(q, dof: int) -> np.ndarray:
    q = np.ascontiguousarray(q, dtype=np.float64)
    if q.shape != (dof,):
        raise KinematicsError(f"q must be a vector of {dof} joint values, got shape {q.shape}")
    return q


def _per_thread(ftab: np.ndarray):
    """Each thread's own copy of the float table (its tail is the scratch the entry writes)."""
    local = threading.local()

    def get() -> np.ndarray:
        local.ftab = ftab.copy()
        return local.ftab

    return local, get


def _compiled_entry(entry, itab, ftab, shape, dof):
    """The compiled ``entry`` for exactly the argument types :func:`_bind` passes, callable without
    numba's dispatcher (``overloads[signature].entry_point``: no typing of the four arguments on each
    call, a third of a single call's cost); the dispatcher itself if this numba has no such attribute."""
    args = (itab, ftab.copy(), np.empty(shape), np.zeros(dof))
    entry(*args)  # compiled, or loaded from the cache, for these types
    try:
        return entry.overloads[tuple(nb.typeof(a) for a in args)].entry_point
    except (AttributeError, KeyError):  # pragma: no cover - another numba's internals
        return entry


def _bind(entry, itab, ftab, shape, dof):
    """``f(q, out=None)`` calling the compiled ``entry`` on pre-bound tables, with each thread's
    own scratch copy of ``ftab`` (the hot path: no lookup beyond the ones below). A ``q`` that is
    a C-contiguous float64 vector of ``dof`` values and no ``out`` take the compiled function
    directly (:func:`_compiled_entry`); other arguments go through numba's dispatcher, which
    checks their types."""
    local, mine = _per_thread(ftab)
    ndarray, f64, empty, qshape, qstrides = np.ndarray, np.dtype(np.float64), np.empty, (dof,), (8,)
    direct = _compiled_entry(entry, itab, ftab, shape, dof)

    def call(q, out=None):
        if q.__class__ is not ndarray or q.dtype is not f64 or q.shape != qshape or q.strides != qstrides:
            q = _coerce(q, dof)
        try:
            f = local.ftab
        except AttributeError:
            f = mine()
        if out is None:
            out = empty(shape)
            direct(itab, f, out, q)
        else:
            entry(itab, f, out, q)
        return out

    return call


def bound_plan_fk(kernel, plan):
    """``f(q, out)`` of :func:`fk_one` for a plan of the batch kernel (the batch path's single
    configuration: ``Kernel.fk`` with one row); ``out`` (L', 4, 4)."""
    itab, ftab = _tables(kernel, plan.order, 0, plan.lj, plan.pose, kernel.poe.dof)
    return _bind(fk_one, itab, ftab, (plan.lj.shape[0], 4, 4), kernel.poe.dof)


def bound_path_jacobian(kernel, link_index: int, code: int):
    """``f(q, out)`` of :func:`jacobian_one` for link ``link_index`` and reference code ``code``
    (the batch path's single configuration: ``Kernel.jacobian`` with one row); ``out`` (6, dof)."""
    path, D = kernel.path_plan(link_index)
    dof = kernel.poe.dof
    itab, ftab = _tables(kernel, path, code, [], D, dof)
    return _bind(jacobian_one, itab, ftab, (6, dof), dof)
