"""The whole self-motion of a redundant chain: its branches, the parameter ranges within the joint
limits, and the best point along it (:mod:`kinematics.algorithms.ik_redundant` gives the slices).

Along the parameter ψ every solution moves smoothly on a **branch**; :func:`track` follows them:

1. a grid of :data:`~kinematics.algorithms.ik_redundant.GRID` values over the parameter's range
   (its limits, else (−π, π]), every slice solved at once (limits ignored: each branch once);
2. a cell (two neighbouring values) is halved -- all cells of all targets in one batch per round --
   while its solutions do not pair off one to one within :data:`~kinematics.algorithms.ik_redundant.MATCH`
   (a fast branch, two branches meeting) or a joint on the same side of its limit at both ends is
   nearer to it than twice its motion across the cell (it might cross and come back inside the cell;
   down to an eighth of the first step: an excursion beyond a limit and back within a narrower range
   is not looked for);
3. solutions of neighbouring values pair off (mutual nearest) into branches; a branch that stops
   inside the range ends where it meets another (two solutions become one, the locked chain is
   singular): that end is found by bisection on the slices to :data:`PSI_TOLERANCE`.

:func:`intervals` finds where each branch enters and leaves the limits: a sign change of its
smallest limit margin between samples is refined by bisection on the slices (each step solves the
slice and follows the branch to its nearest solution) to :data:`PSI_TOLERANCE`, so an end is a
joint at its limit to that tolerance, a parameter limit, or a branch end -- each named.
:func:`best` evaluates an objective on every sample of every in-limit piece and refines each local
optimum by golden-section search on the slices (its two neighbouring samples bracket it).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .ik_all import newton
from .ik_redundant import GRID, MATCH, PSI_TOLERANCE, REFINE_ROUNDS, SelfMotion

#: bisection / golden-section steps at most (the bracket shrinks below PSI_TOLERANCE long before)
MAX_STEPS = 80
#: a cell is not halved below this width (rad or m); for a joint near its limit, not below the grid's
#: step / LIMIT_SPLITS
MIN_CELL, LIMIT_SPLITS = 1e-4, 8
GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0
#: Newton steps on the best point (at its parameter value)
POLISH_STEPS = 60


@dataclass
class Branch:
    """One branch of one target: samples ``psi`` (S,) increasing and ``q`` (S, dof) along it, and why it
    starts and ends (``"parameter_limit"``, ``"range_end"``: the end of (−π, π] for an unlimited
    parameter, ``"branch_end"``: it meets another branch there)."""

    psi: list
    q: list
    m: list
    start: str = "parameter_limit"
    end: str = "parameter_limit"


@dataclass
class Piece:
    """A range ``[lo, hi]`` of branch ``branch`` inside the limits, and why it starts and ends
    (``{"reason": "joint_limit", "joint": name}``, or the branch's own reason)."""

    branch: int
    lo: float
    hi: float
    ends: list = field(default_factory=list)
    #: the solutions and limit margins at lo and hi
    q: list = field(default_factory=lambda: [None, None])
    m: list = field(default_factory=lambda: [None, None])

    def as_dict(self) -> dict:
        return {"branch": self.branch, "from": self.lo, "to": self.hi, "ends": self.ends}


def domain(motion: SelfMotion) -> tuple[float, float, str]:
    """The parameter's range and what bounds it."""
    if np.isfinite(motion.lower) and np.isfinite(motion.upper):
        return motion.lower, motion.upper, "parameter_limit"
    return -np.pi, np.pi, "range_end"


def _cols(motion: SelfMotion) -> np.ndarray:
    return motion.chain.columns


def _dist(motion: SelfMotion, A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Largest joint difference (angles modulo 2π) of each row of A (K, dof) from b (dof,), the
    parameter joint left out."""
    c, rev = _cols(motion), motion.chain.revolute
    d = A[:, c] - b[c]
    d = np.where(rev, np.mod(d + np.pi, 2 * np.pi) - np.pi, d)
    d[:, motion.k] = 0.0
    return np.abs(d).max(axis=1) if len(A) else np.zeros(0)


def _solve(motion: SelfMotion, T_root: np.ndarray, targets: np.ndarray, psi: np.ndarray) -> list:
    """The solutions (K, dof) of each pair (target, ψ), limits ignored, and their limit margins (K, n)."""
    if not len(psi):
        return []
    sl = motion.solve(T_root[targets], psi, exact=True)
    M = motion.margins(sl.q)
    return [(sl.q[r, :sl.count[r]], M[r, :sl.count[r]]) for r in range(len(psi))]


def _pair(motion: SelfMotion, A: np.ndarray, B: np.ndarray) -> list[tuple[int, int, float]]:
    """Mutual-nearest pairs (i, j, distance) of the solutions A and B of neighbouring values."""
    if not len(A) or not len(B):
        return []
    c, rev = _cols(motion), motion.chain.revolute
    d = A[:, None, c] - B[None, :, c]
    d = np.abs(np.where(rev, np.mod(d + np.pi, 2 * np.pi) - np.pi, d))
    d[..., motion.k] = 0.0
    D = d.max(axis=2)  # (|A|, |B|)
    j = D.argmin(axis=1)
    i = np.arange(len(A))
    ok = (D.argmin(axis=0)[j] == i) & (D[i, j] < MATCH)
    return [(int(a), int(b), float(D[a, b])) for a, b in zip(i[ok], j[ok])]


def _cell_unclear(motion: SelfMotion, a, b, width, limit_width) -> bool:
    """A cell to halve: its solutions do not pair off one to one, or a paired joint, on the same side of
    its limit at both ends, is nearer to it than twice its motion across the cell."""
    if width <= MIN_CELL:
        return False
    (A, MA), (B, MB) = a, b
    pairs = _pair(motion, A, B)
    if len(pairs) != len(A) or len(pairs) != len(B):
        return True
    if not pairs or width <= limit_width:
        return False
    i, j = np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])
    mA, mB = MA[i], MB[j]
    c, rev = _cols(motion), motion.chain.revolute
    d = A[i][:, c] - B[j][:, c]
    moved = np.abs(np.where(rev, np.mod(d + np.pi, 2 * np.pi) - np.pi, d))
    return bool(np.any((np.minimum(np.abs(mA), np.abs(mB)) < 2 * moved) & (np.sign(mA) == np.sign(mB))))


def track(motion: SelfMotion, T_root: np.ndarray, grid: int = GRID) -> list[list[Branch]]:
    """The branches of each target (see the module text)."""
    N = len(T_root)
    lo, hi, bound = domain(motion)
    psi0 = np.linspace(lo, hi, grid)
    sols = _solve(motion, T_root, np.repeat(np.arange(N), grid), np.tile(psi0, N))
    samples = [dict(zip(psi0.tolist(), sols[n * grid:(n + 1) * grid])) for n in range(N)]
    pending = [list(zip(psi0[:-1].tolist(), psi0[1:].tolist())) for _ in range(N)]
    for _ in range(REFINE_ROUNDS):
        split = [(n, a, b) for n in range(N) for a, b in pending[n]
                 if _cell_unclear(motion, samples[n][a], samples[n][b], b - a, (hi - lo) / (grid - 1) / LIMIT_SPLITS)]
        if not split:
            break
        pending = [[] for _ in range(N)]
        mids = [(a + b) / 2 for _, a, b in split]
        for (n, a, b), m, S in zip(split, mids, _solve(motion, T_root, np.array([x[0] for x in split]),
                                                        np.array(mids))):
            samples[n][m] = S
            pending[n] += [(a, m), (m, b)]
    branches = [_branches(motion, samples[n], bound) for n in range(N)]
    _refine_branch_ends(motion, T_root, branches)
    return branches


def _branches(motion: SelfMotion, samples: dict, bound: str) -> list[Branch]:
    ps = sorted(samples)
    Q0, M0 = samples[ps[0]]
    open_: dict[int, Branch] = {i: Branch([ps[0]], [Q0[i]], [M0[i]], start=bound) for i in range(len(Q0))}
    done: list[Branch] = []
    for a, b in zip(ps[:-1], ps[1:]):
        (A, _), (B, MB) = samples[a], samples[b]
        pairs = {i: j for i, j, _ in _pair(motion, A, B)}
        nxt: dict[int, Branch] = {}
        for i, br in open_.items():
            if i in pairs:
                br.psi.append(b)
                br.q.append(B[pairs[i]])
                br.m.append(MB[pairs[i]])
                nxt[pairs[i]] = br
            else:
                br.end = "branch_end"
                done.append(br)
        for j in range(len(B)):
            if j not in nxt:
                nxt[j] = Branch([b], [B[j]], [MB[j]], start="branch_end")
        open_ = nxt
    for br in open_.values():
        br.end = bound
        done.append(br)
    return sorted(done, key=lambda br: (br.psi[0], br.psi[-1]))


def _bisect(motion, T_root, jobs, inside, value=None):
    """Root-finding on many brackets at once. ``jobs``: lists ``[target, a, b, q_a, m_a]`` where ψ = a holds
    (``inside(m_a)`` true of the limit margins at q_a) and ψ = b does not; each step solves every new
    point in one batch and follows the branch from q_a to its nearest solution (a lost branch counts as
    ``inside`` false). Returns the jobs with [a, b] below :data:`PSI_TOLERANCE` (a and q_a the last
    point that holds).

    Without ``value`` a step halves the bracket. With ``value`` (margins -> a number, continuous along
    the branch and >= 0 exactly where ``inside`` holds: the smallest limit margin, smooth in ψ on each
    branch between the joints' crossings) and the margins at b as a sixth entry of each job, a step is
    the Illinois variant of regula falsi (superlinear; it never leaves the bracket), and the new point
    c is also tried at c ± PSI_TOLERANCE / 2, which closes the bracket once c is that near the root.
    A lost branch, or two steps that did not halve the bracket, fall back to halving. (A branch's end,
    where it meets another, is found by halving: which solution is its partner is not known there.)"""
    # per job: f(a), f(b), the end that moved last, steps in a row that did not halve the bracket
    state = {id(j): [value(j[4]), value(j[5]), -1, 0] if value is not None and len(j) > 5 else None for j in jobs}
    for _ in range(MAX_STEPS):
        todo = [j for j in jobs if abs(j[2] - j[1]) > PSI_TOLERANCE]
        if not todo:
            break
        points, owner, primary, widths = [], [], [], {}
        for j in todo:
            st = state[id(j)]
            a, b = j[1], j[2]
            widths[id(j)] = abs(b - a)
            if st is None or st[3] >= 2 or not st[0] > st[1]:
                points.append((a + b) / 2); owner.append(j); primary.append(True)
                if st is not None:
                    st[3] = 0
                continue
            c = b - st[1] * (b - a) / (st[1] - st[0])
            for x, first in ((c, True), (c - PSI_TOLERANCE / 2, False), (c + PSI_TOLERANCE / 2, False)):
                if min(a, b) < x < max(a, b):
                    points.append(x); owner.append(j); primary.append(first)
        sols = _solve(motion, T_root, np.array([j[0] for j in owner]), np.array(points))
        for j, x, first, (S, MS) in zip(owner, points, primary, sols):
            if not (min(j[1], j[2]) < x < max(j[1], j[2])):
                continue  # the bracket already closed past this point
            d = _dist(motion, S, j[3])
            k = int(np.argmin(d)) if len(d) else -1
            found = k >= 0 and d[k] < MATCH
            st = state[id(j)]
            if found and inside(MS[k]):
                j[1], j[3], j[4] = float(x), S[k], MS[k]
                if st is not None:
                    st[0] = value(MS[k])
                    if first and st[2] == 0:
                        st[1] /= 2  # Illinois: the same end moved twice, the other end's value halved
                    st[2] = 0 if first else st[2]
            else:
                j[2] = float(x)
                if st is not None and not found:
                    state[id(j)] = None  # the branch is lost there: halving from now on
                elif st is not None:
                    st[1] = value(MS[k])
                    if first and st[2] == 1:
                        st[0] /= 2
                    st[2] = 1 if first else st[2]
        for j in todo:
            st = state[id(j)]
            if st is not None:
                st[3] = st[3] + 1 if abs(j[2] - j[1]) > widths[id(j)] / 2 else 0
    return jobs


def _refine_branch_ends(motion, T_root, branches):
    """Each branch end inside the range moved to where the branch stops, to PSI_TOLERANCE."""
    jobs, where = [], []
    for n, brs in enumerate(branches):
        for br in brs:
            ps = None
            if br.end == "branch_end":
                ps = _neighbour(branches[n], br.psi[-1], +1)
                if ps is not None:
                    jobs.append([n, br.psi[-1], ps, br.q[-1], br.m[-1]]); where.append((br, -1))
            if br.start == "branch_end":
                ps = _neighbour(branches[n], br.psi[0], -1)
                if ps is not None:
                    jobs.append([n, br.psi[0], ps, br.q[0], br.m[0]]); where.append((br, 0))
    for (br, side), job in zip(where, _bisect(motion, T_root, jobs, lambda q: True)):
        if side == -1:
            br.psi.append(job[1]); br.q.append(job[3]); br.m.append(job[4])
        else:
            br.psi.insert(0, job[1]); br.q.insert(0, job[3]); br.m.insert(0, job[4])


def _neighbour(brs, psi, direction):
    """The nearest sample value of any branch of the target beyond ``psi`` in ``direction``."""
    vals = sorted({p for br in brs for p in br.psi})
    i = vals.index(psi)
    j = i + direction
    return vals[j] if 0 <= j < len(vals) else None


def intervals(motion: SelfMotion, T_root: np.ndarray, branches: list[list[Branch]] | None = None):
    """Per target its in-limit :class:`Piece` s (:func:`merged` makes them the answer's ranges) and the
    branches (see the module text)."""
    branches = track(motion, T_root) if branches is None else branches
    model, chain, names = motion.model, motion.chain, motion.chain.joints
    pieces: list[list[Piece]] = [[] for _ in branches]
    jobs, owners = [], []
    for n, brs in enumerate(branches):
        for b, br in enumerate(brs):
            m = np.array(br.m).min(axis=1)
            ok = m >= 0
            s = 0
            while s < len(ok):
                if not ok[s]:
                    s += 1
                    continue
                e = s
                while e + 1 < len(ok) and ok[e + 1]:
                    e += 1
                piece = Piece(b, br.psi[s], br.psi[e], [{"reason": br.start}, {"reason": br.end}],
                              [br.q[s], br.q[e]], [br.m[s], br.m[e]])
                if s > 0:  # enters the limits between samples s-1 and s
                    jobs.append([n, br.psi[s], br.psi[s - 1], br.q[s], br.m[s], br.m[s - 1]])
                    owners.append((piece, 0))
                if e < len(ok) - 1:
                    jobs.append([n, br.psi[e], br.psi[e + 1], br.q[e], br.m[e], br.m[e + 1]])
                    owners.append((piece, 1))
                pieces[n].append(piece)
                s = e + 1
    inside = lambda m: m.min() >= 0  # noqa: E731
    for (piece, side), job in zip(owners, _bisect(motion, T_root, jobs, inside, value=lambda m: float(m.min()))):
        at = int(np.argmin(job[4]))
        if side == 0:
            piece.lo = job[1]
        else:
            piece.hi = job[1]
        piece.q[side], piece.m[side] = job[3], job[4]
        piece.ends[side] = {"reason": "joint_limit", "joint": names[at]}
    return pieces, branches


def merged(pieces: list[Piece]) -> list[dict]:
    """The pieces of one target as sorted disjoint ranges ``{"from", "to", "branches": [piece, ...]}``."""
    return _merge(pieces)


def _merge(pieces: list[Piece]) -> list[dict]:
    out: list[dict] = []
    for p in sorted(pieces, key=lambda p: p.lo):
        if out and p.lo <= out[-1]["to"]:
            out[-1]["to"] = max(out[-1]["to"], p.hi)
            out[-1]["branches"].append(p.as_dict())
        else:
            out.append({"from": p.lo, "to": p.hi, "branches": [p.as_dict()]})
    return out


# ---------------------------------------------------------------------------------- the best point
@dataclass(frozen=True)
class Objective:
    """What :func:`best` maximises over the in-limit self-motion: ``name`` one of ``"nearest"`` (minus
    the Euclidean distance over the chain's joints to ``seed``, each joint's in-limit 2π copy nearest
    it), ``"margin"`` (the smallest distance to a limit, each joint's divided by its range),
    ``"manipulability"`` (√det(J Jᵀ), the chain's Jacobian at the link, world axes). A strategy object:
    ``values(motion, Q, M)`` scores rows, ``finish(motion, q)`` picks the answer's 2π copies."""

    name: str
    seed: np.ndarray | None = None

    def values(self, motion: SelfMotion, Q: np.ndarray, M: np.ndarray) -> np.ndarray:
        Q, M = np.atleast_2d(Q), np.atleast_2d(M)
        if self.name == "margin":
            cols = motion.chain.columns
            span = (motion.model.upper_limits - motion.model.lower_limits)[cols]
            return np.where(np.isfinite(span), M / span, np.inf).min(axis=1)
        if self.name == "nearest":
            return -np.linalg.norm(self._copies(motion, Q)[:, motion.chain.columns]
                                   - self.seed[motion.chain.columns], axis=1)
        J = motion.poe.jacobian(Q, motion.link, "local_world_aligned", tool=motion.tool)[:, :, motion.chain.columns]
        return np.sqrt(np.maximum(np.linalg.det(J @ np.swapaxes(J, 1, 2)), 0.0))

    def _copies(self, motion: SelfMotion, Q: np.ndarray) -> np.ndarray:
        """Each chain joint of ``Q`` moved by 2πk to its in-limit copy nearest the seed (largest margin
        without a seed)."""
        cols, lo, hi, periodic = motion._limits
        out = np.array(Q, dtype=float)
        x = out[:, cols]
        ref = self.seed[cols] if self.seed is not None else (lo + hi) / 2
        best, score = x.copy(), np.where((x >= lo - 1e-12) & (x <= hi + 1e-12), -np.abs(x - ref), -np.inf)
        for k in (-2, -1, 1, 2):
            y = x + 2 * np.pi * k
            sc = np.where(periodic & (y >= lo - 1e-12) & (y <= hi + 1e-12), -np.abs(y - ref), -np.inf)
            best, score = np.where(sc > score, y, best), np.maximum(sc, score)
        out[:, cols] = best
        return out

    def finish(self, motion: SelfMotion, q: np.ndarray) -> np.ndarray:
        return self._copies(motion, q[None])[0]


@dataclass
class Best:
    """The best in-limit point of a target's self-motion: ``q`` (dof,), ``parameter``, ``value`` (the
    objective), ``branch``; None where no solution lies within the limits."""

    q: np.ndarray
    parameter: float
    value: float
    branch: int


def piece_samples(piece: Piece, branch: Branch) -> tuple[list[float], np.ndarray, np.ndarray]:
    """The samples of ``branch`` on ``piece``, its ends included, in ψ order: ``(ψ, q, m)``."""
    idx = [i for i, p in enumerate(branch.psi) if piece.lo < p < piece.hi]
    psi = [piece.lo] + [branch.psi[i] for i in idx] + [piece.hi]
    Q = np.array([piece.q[0]] + [branch.q[i] for i in idx] + [piece.q[1]])
    M = np.array([piece.m[0]] + [branch.m[i] for i in idx] + [piece.m[1]])
    return psi, Q, M


def best(motion: SelfMotion, T_root: np.ndarray, objective: Objective, pieces: list[list[Piece]] | None = None,
         branches: list[list[Branch]] | None = None) -> list[Best | None]:
    """The best point of each target's in-limit self-motion (see the module text)."""
    if pieces is None:
        pieces, branches = intervals(motion, T_root, branches)
    out: list[Best | None] = []
    jobs = []
    free = np.delete(motion.chain.columns, motion.k)
    for n, (ps, brs) in enumerate(zip(pieces, branches)):
        top = None
        for piece in ps:
            psi, Q, M = piece_samples(piece, brs[piece.branch])
            f = objective.values(motion, Q, M)
            for i in range(len(psi)):
                if (i == 0 or f[i] >= f[i - 1]) and (i == len(psi) - 1 or f[i] >= f[i + 1]):
                    if 0 < i < len(psi) - 1:
                        jobs.append(_golden_job(n, psi[i - 1], psi[i + 1], psi[i], Q[i], f[i], piece.branch))
                    if top is None or f[i] > top.value:
                        top = Best(Q[i], psi[i], float(f[i]), piece.branch)
        out.append(top)
    for job in _golden(motion, T_root, objective, jobs):
        n = job["target"]
        if out[n] is None or job["f"] > out[n].value:
            out[n] = Best(job["q"], job["x"], float(job["f"]), job["branch"])
    for n, b in enumerate(out):
        if b is not None:  # Newton at the parameter value: a double root (a branch end) to machine precision
            b.q = objective.finish(motion, newton(motion.poe, motion.link, b.q[None], T_root[n:n + 1], free,
                                                  POLISH_STEPS, motion.tool)[0])
            b.value = float(objective.values(motion, b.q, motion.margins(b.q))[0])
    return out


def _golden_job(n, a, b, x, q, f, branch):
    return {"target": n, "a": a, "b": b, "x": x, "q": q, "f": f, "branch": branch}


def _golden(motion, T_root, objective, jobs):
    """Golden-section search of many brackets ``[a, b]`` at once (each holding its best point ``x``, its
    solution ``q`` and value ``f``): each step evaluates one new point per bracket, on the slice at that
    value, following the branch from the nearest known point (a lost branch or a point outside the
    limits scores −∞)."""
    for job in jobs:
        a, b = job["a"], job["b"]
        job["pts"] = {job["x"]: (job["f"], job["q"])}
        job["x1"], job["x2"] = b - GOLDEN * (b - a), a + GOLDEN * (b - a)
    need = [(job, job["x1"]) for job in jobs] + [(job, job["x2"]) for job in jobs]
    for _ in range(MAX_STEPS):
        if not need:
            break
        sols = _solve(motion, T_root, np.array([j["target"] for j, _ in need]), np.array([x for _, x in need]))
        for (job, x), (S, MS) in zip(need, sols):
            near = min(job["pts"], key=lambda p: abs(p - x))
            ref = job["pts"][near][1]
            d = _dist(motion, S, ref)
            k = int(np.argmin(d)) if len(d) else -1
            if k >= 0 and d[k] < MATCH and MS[k].min() >= 0:
                f = float(objective.values(motion, S[k], MS[k])[0])
                job["pts"][x] = (f, S[k])
            else:
                job["pts"][x] = (-np.inf, ref)
        need = []
        for job in jobs:
            if job["b"] - job["a"] <= PSI_TOLERANCE:
                continue
            f1, f2 = job["pts"][job["x1"]][0], job["pts"][job["x2"]][0]
            if f1 >= f2:
                job["b"], job["x2"] = job["x2"], job["x1"]
                job["x1"] = job["b"] - GOLDEN * (job["b"] - job["a"])
                need.append((job, job["x1"]))
            else:
                job["a"], job["x1"] = job["x1"], job["x2"]
                job["x2"] = job["a"] + GOLDEN * (job["b"] - job["a"])
                need.append((job, job["x2"]))
    for job in jobs:
        x = max(job["pts"], key=lambda p: job["pts"][p][0])
        job["x"], (job["f"], job["q"]) = x, job["pts"][x]
    return jobs
