"""Compiled (numba) inverse kinematics: damped least squares on the engine's own FK and Jacobian.

For each target ``T_root_link`` (one per row of ``Q``) the kernel iterates

    e = (p_target - p(q),  log(R_target R(q)^T))          (world axes; 3 rows in position mode)
    (J^T J + λ I) Δq = J^T e,     λ = ½ |e|² + λ_min      (Sugihara's damping)

with ``J`` the ``local_world_aligned`` Jacobian of the link (origin velocity and angular
velocity in world axes), over the q columns of the joints on the root-to-link path only
(the others keep the seed's values; a mimic joint's column is its leader's, times its
multiplier). The frames come from the same ``_chunk_frames`` as FK and Jacobians.

**Joint limits are part of the step** (an active set): a column whose step would leave its
limits is moved onto the limit and taken out, and the remaining columns are solved again for
what is left of the error (the null space takes up the motion). A revolute joint whose new
angle is outside its limits but a whole turn away from a value inside them takes that value
instead (a joint with ±2π limits is never stuck at one end). Continuous joints wrap into
[-π, π]. An attempt ends when the errors are within the tolerances or after ``max_iter``
steps; then a new attempt starts from a configuration drawn uniformly within the limits, up
to ``restarts`` times. The draws come from a splitmix64 stream per target, seeded by the
caller (a hash of the target and the random seed), so an answer depends only on its own
target, seed and options: a target solved alone gets the answer it gets in a batch.

The best configuration seen (the smallest error relative to the tolerances) is returned with
its errors and the number of steps taken over all attempts.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

# the FK kernel's chunk walk and scratch buffers, private to the engine: IK evaluates the same frames
from .compiled import J_KIND, J_MULT, J_QINDEX, REVOLUTE, _chunk_frames, _scratch, joint_column

_JIT = dict(cache=True, nogil=True, boundscheck=False, error_model="numpy")

#: modes of the kernel
MODE_POSE, MODE_POSITION = 0, 1

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)


@nb.njit(**_JIT)
def _splitmix(state):
    """(next state, a uniform number in [0, 1)) of a splitmix64 stream."""
    state = state + _GOLDEN
    z = state
    z = (z ^ (z >> np.uint64(30))) * _MIX1
    z = (z ^ (z >> np.uint64(27))) * _MIX2
    z = z ^ (z >> np.uint64(31))
    return state, float(z >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@nb.njit(**_JIT)
def rotation_log(R, out):
    """The rotation vector (axis times angle, angle in [0, π]) of a 3x3 rotation, into ``out``."""
    vx = 0.5 * (R[2, 1] - R[1, 2])
    vy = 0.5 * (R[0, 2] - R[2, 0])
    vz = 0.5 * (R[1, 0] - R[0, 1])
    s = math.sqrt(vx * vx + vy * vy + vz * vz)
    c = 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)
    if c > 1.0:
        c = 1.0
    elif c < -1.0:
        c = -1.0
    theta = math.atan2(s, c)
    if c > -0.99:  # away from a half turn: the skew part is well conditioned
        k = theta / s if s > 1e-300 else 1.0
        out[0], out[1], out[2] = vx * k, vy * k, vz * k
        return
    # near a half turn: the axis from the symmetric part, its sign from the skew part
    d0 = max((R[0, 0] - c) / (1.0 - c), 0.0)
    d1 = max((R[1, 1] - c) / (1.0 - c), 0.0)
    d2 = max((R[2, 2] - c) / (1.0 - c), 0.0)
    if d0 >= d1 and d0 >= d2:
        ux = math.sqrt(d0)
        uy = (R[0, 1] + R[1, 0]) / (2.0 * (1.0 - c) * ux)
        uz = (R[0, 2] + R[2, 0]) / (2.0 * (1.0 - c) * ux)
    elif d1 >= d2:
        uy = math.sqrt(d1)
        ux = (R[0, 1] + R[1, 0]) / (2.0 * (1.0 - c) * uy)
        uz = (R[1, 2] + R[2, 1]) / (2.0 * (1.0 - c) * uy)
    else:
        uz = math.sqrt(d2)
        ux = (R[0, 2] + R[2, 0]) / (2.0 * (1.0 - c) * uz)
        uy = (R[1, 2] + R[2, 1]) / (2.0 * (1.0 - c) * uz)
    n = math.sqrt(ux * ux + uy * uy + uz * uz)
    if ux * vx + uy * vy + uz * vz < 0.0:
        n = -n
    out[0], out[1], out[2] = theta * ux / n, theta * uy / n, theta * uz / n


@nb.njit(**_JIT)
def _evaluate(q, target, jint, jflt, path, D, cols, F, W, J, e, R, Rerr, rv):
    """Frames of ``q`` (1, dof); the error ``e`` (6,) to ``target``; the Jacobian ``J`` (6, nv)
    over ``cols``. Returns (position error, rotation error)."""
    _chunk_frames(q, 0, 1, path, jint, jflt, F, W)
    Fl = F[path[path.shape[0] - 1]]
    o = np.empty(3)
    for r in range(3):
        f0, f1, f2, f3 = Fl[4 * r, 0], Fl[4 * r + 1, 0], Fl[4 * r + 2, 0], Fl[4 * r + 3, 0]
        o[r] = f0 * D[0, 3] + f1 * D[1, 3] + f2 * D[2, 3] + f3
        for c in range(3):
            R[r, c] = f0 * D[0, c] + f1 * D[1, c] + f2 * D[2, c]
    for r in range(3):
        e[r] = target[r, 3] - o[r]
    for r in range(3):  # R_err = R_target R^T
        for c in range(3):
            Rerr[r, c] = target[r, 0] * R[c, 0] + target[r, 1] * R[c, 1] + target[r, 2] * R[c, 2]
    rotation_log(Rerr, rv)
    e[3], e[4], e[5] = rv[0], rv[1], rv[2]
    J[:, :] = 0.0
    for jj in range(path.shape[0]):
        j = path[jj]
        Fj = F[j]
        vx, vy, vz, ax, ay, az = joint_column(Fj, 0, jint[j, J_KIND] == REVOLUTE, o[0], o[1], o[2])
        col = jint[j, J_QINDEX]
        k = 0
        while cols[k] != col:  # the column's place among the moving columns (nv is small)
            k += 1
        mu = jflt[j, J_MULT]
        J[0, k] += mu * vx
        J[1, k] += mu * vy
        J[2, k] += mu * vz
        J[3, k] += mu * ax
        J[4, k] += mu * ay
        J[5, k] += mu * az
    pe = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    re = math.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5])
    return pe, re


@nb.njit(**_JIT)
def _turned_inside(v, lo, hi):
    """Whether an angle ``v`` outside ``[lo, hi]`` is a whole number of turns from a value inside."""
    return lo + (v - lo) % (2.0 * math.pi) <= hi


@nb.njit(**_JIT)
def streams(targets, seeds, random_seed):
    """A 64-bit stream seed per row (N,): a hash of the bits of its target (N, 4, 4), its seed
    (N, dof) and ``random_seed`` (splitmix64's mixing), so that an answer depends only on its
    own inputs."""
    N = targets.shape[0]
    tb = np.ascontiguousarray(targets).reshape(N * 16).view(np.uint64)
    sb = np.ascontiguousarray(seeds).reshape(seeds.size).view(np.uint64)
    dof = seeds.shape[1]
    out = np.empty(N, dtype=np.uint64)
    for i in range(N):
        h = np.uint64(random_seed)
        for k in range(16):
            h = (h ^ tb[i * 16 + k]) * _MIX1
            h = h ^ (h >> np.uint64(29))
        for k in range(dof):
            h = (h ^ sb[i * dof + k]) * _MIX1
            h = h ^ (h >> np.uint64(29))
        h = (h ^ (h >> np.uint64(30))) * _MIX1
        h = (h ^ (h >> np.uint64(27))) * _MIX2
        out[i] = h ^ (h >> np.uint64(31))
    return out


@nb.njit(**_JIT)
def measure(T, targets, Q, lower, upper, limit_tol, tol_p, tol_r, position_only, perr, rerr, ok):
    """The answers' own errors and success, from their poses ``T`` (N, 4, 4) (computed by the FK
    kernel, independently of the solver): position distance and rotation angle (atan2 of the
    skew and symmetric parts of ``R_target^T R``) to ``targets``, and every joint of ``Q`` within
    its limits (± ``limit_tol``)."""
    N, dof = Q.shape
    for i in range(N):
        dx = targets[i, 0, 3] - T[i, 0, 3]
        dy = targets[i, 1, 3] - T[i, 1, 3]
        dz = targets[i, 2, 3] - T[i, 2, 3]
        pe = math.sqrt(dx * dx + dy * dy + dz * dz)
        m = np.empty((3, 3))
        for r in range(3):
            for c in range(3):
                m[r, c] = targets[i, 0, r] * T[i, 0, c] + targets[i, 1, r] * T[i, 1, c] + targets[i, 2, r] * T[i, 2, c]
        s = 0.5 * math.sqrt((m[2, 1] - m[1, 2]) ** 2 + (m[0, 2] - m[2, 0]) ** 2 + (m[1, 0] - m[0, 1]) ** 2)
        cth = 0.5 * (m[0, 0] + m[1, 1] + m[2, 2] - 1.0)
        re = math.atan2(s, cth)
        inside = True
        for c in range(dof):
            if Q[i, c] < lower[c] - limit_tol or Q[i, c] > upper[c] + limit_tol:
                inside = False
        perr[i] = pe
        rerr[i] = re
        ok[i] = inside and pe <= tol_p and (position_only or re <= tol_r)


@nb.njit(**_JIT)
def _damped_step(J, e, rows, free, lam, A, g, x):
    """Solve ``(J_f^T J_f + λ I) x_f = J_f^T e`` over the free columns (Cholesky); x = 0 elsewhere."""
    nv = J.shape[1]
    idx = np.empty(nv, dtype=np.int64)
    m = 0
    for c in range(nv):
        if free[c]:
            idx[m] = c
            m += 1
    for a in range(m):
        ca = idx[a]
        s = 0.0
        for r in range(rows):
            s += J[r, ca] * e[r]
        g[a] = s
        for b in range(a + 1):
            cb = idx[b]
            s = 0.0
            for r in range(rows):
                s += J[r, ca] * J[r, cb]
            A[a, b] = s
        A[a, a] += lam
    for a in range(m):  # Cholesky: A = L L^T, L in the lower triangle of A
        for b in range(a + 1):
            s = A[a, b]
            for k in range(b):
                s -= A[a, k] * A[b, k]
            if a == b:
                A[a, a] = math.sqrt(s) if s > 0.0 else 1e-300
            else:
                A[a, b] = s / A[b, b]
    for a in range(m):  # L y = g
        s = g[a]
        for k in range(a):
            s -= A[a, k] * g[k]
        g[a] = s / A[a, a]
    for a in range(m - 1, -1, -1):  # L^T x = y
        s = g[a]
        for k in range(a + 1, m):
            s -= A[k, a] * g[k]
        g[a] = s / A[a, a]
    for c in range(nv):
        x[c] = 0.0
    for a in range(m):
        x[idx[a]] = g[a]


@nb.njit(**_JIT)
def solve(Q, targets, joints, chain, settings, rng, outputs):
    """Inverse kinematics of every row: ``Q`` (N, dof) holds the seeds and receives the answers.

    targets: (N, 4, 4) ``T_root_link``. ``joints = (lower, upper, wrap, angular)``: (dof,) limits
    (±inf: none), continuous joints, revolute and continuous joints (a whole turn changes nothing).
    ``chain = (cols, jint, jflt, path, D)``: (nv,) the q columns the path moves, then the path as
    the Jacobian kernel takes it. ``settings = (mode, tol_p, tol_r, max_iter, restarts, lam_min,
    polish, stall)``: mode MODE_POSE or MODE_POSITION; the tolerances (an attempt goes on until its
    errors are within ``polish`` times them, a margin, but a solution within them ends the search);
    steps per attempt, restarts and the least damping; ``stall``: an attempt whose error has not
    fallen by 1 % in this many steps is stuck (a local minimum, or pinned at a limit) and ends
    early. rng: (N,) uint64 stream seeds. ``outputs = (perr, rerr, iters)``: (N,) written, the
    errors of the answer and the steps taken.
    """
    lower, upper, wrap, angular = joints
    cols, jint, jflt, path, D = chain
    mode, tol_p, tol_r, max_iter, restarts, lam_min, polish, stall = settings
    perr, rerr, iters = outputs
    N, dof = Q.shape
    nv = cols.shape[0]
    rows = 3 if mode == MODE_POSITION else 6
    F, W = _scratch(jint.shape[0], 1)
    q = np.empty((1, dof))
    best = np.empty(dof)
    J = np.zeros((6, nv))
    e = np.empty(6)
    R = np.empty((3, 3))
    Rerr = np.empty((3, 3))
    rv = np.empty(3)
    A = np.empty((nv, nv))
    g = np.empty(nv)
    x = np.empty(nv)
    free = np.empty(nv, dtype=np.bool_)
    res = np.empty(6)
    for i in range(N):
        state = rng[i]
        target = targets[i]
        for c in range(dof):
            q[0, c] = Q[i, c]
            best[c] = Q[i, c]
        best_score = np.inf
        best_pe = np.inf
        best_re = np.inf
        steps = 0
        for attempt in range(restarts + 1):
            if attempt > 0:  # a new start, uniform within the limits (continuous: a full turn)
                for k in range(nv):
                    c = cols[k]
                    state, u = _splitmix(state)
                    lo, hi = lower[c], upper[c]
                    if not (math.isfinite(lo) and math.isfinite(hi)):
                        lo, hi = -math.pi, math.pi
                    q[0, c] = lo + (hi - lo) * u
            attempt_best = np.inf
            since = 0
            for it in range(max_iter + 1):
                pe, re = _evaluate(q, target, jint, jflt, path, D, cols, F, W, J, e, R, Rerr, rv)
                score = pe / tol_p if mode == MODE_POSITION else max(pe / tol_p, re / tol_r)
                if score < 0.99 * attempt_best:
                    attempt_best = score
                    since = 0
                else:
                    since += 1
                if score < best_score:
                    best_score, best_pe, best_re = score, pe, re
                    for c in range(dof):
                        best[c] = q[0, c]
                if score <= polish or it == max_iter or since >= stall:
                    break
                steps += 1
                energy = 0.0
                for r in range(rows):
                    energy += e[r] * e[r]
                lam = 0.5 * energy + lam_min
                # damped step, then the limits: a column that would leave them goes onto the
                # limit and out of the solve, and the others take up the rest of the error
                for k in range(nv):
                    free[k] = True
                for r in range(rows):
                    res[r] = e[r]
                for _ in range(nv):
                    _damped_step(J, res, rows, free, lam, A, g, x)
                    hit = False
                    for k in range(nv):
                        if not free[k]:
                            continue
                        c = cols[k]
                        v = q[0, c] + x[k]
                        if (v < lower[c] or v > upper[c]) and not (angular[c] and _turned_inside(v, lower[c], upper[c])):
                            limit = lower[c] if v < lower[c] else upper[c]
                            dx = limit - q[0, c]
                            q[0, c] = limit
                            free[k] = False
                            hit = True
                            for r in range(rows):
                                res[r] -= J[r, k] * dx
                    if not hit:
                        break
                for k in range(nv):
                    if free[k]:
                        c = cols[k]
                        v = q[0, c] + x[k]
                        if wrap[c]:  # into [-π, π]
                            v -= 2.0 * math.pi * np.rint(v / (2.0 * math.pi))
                        elif angular[c] and (v < lower[c] or v > upper[c]):  # a whole turn back inside
                            v = lower[c] + (v - lower[c]) % (2.0 * math.pi)
                        q[0, c] = v
            if best_score <= 1.0:
                break
        for c in range(dof):
            Q[i, c] = best[c]
        perr[i] = best_pe
        rerr[i] = best_re
        iters[i] = steps
