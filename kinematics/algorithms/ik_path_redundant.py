"""Cartesian paths of a redundant (7-joint) chain that move along its self-motion.

A 6-joint chain has finitely many solutions per target, and :func:`~kinematics.algorithms.ik_path.cartesian_path`
follows the nearest; where that branch leaves the limits or ends, the path stops with ``joint_jump``.
A 7-joint chain has a one-dimensional set per target (its self-motion, run by a parameter ψ: a joint's
value, :class:`~kinematics.algorithms.ik_redundant.SelfMotion`), and the path may choose ψ at every
target. :func:`self_motion_path` chooses it by **continuation along the branch**:

1. the first row: with a seed, the point of the first target's whole self-motion nearest it (the
   seed's own slice solution when it reaches the first waypoint inside the limits: no search); without one, the best point of the whole
   self-motion for the objective (:func:`~kinematics.algorithms.ik_self_motion.best`; ``nearest``: to
   the middle of the limits);
2. each next target: the slices at :data:`WINDOW` values on each side of the previous row's ψ, at
   most ``max_joint_step`` away (and within the parameter's limits), solved in one batch; the branch of
   the previous row is followed over them from the solution nearest it (each sample's solution nearest
   the last one followed, within :data:`~kinematics.algorithms.ik_redundant.MATCH`; revolute angles
   taken as the ``2πk`` copy nearest the previous row). Its samples inside the joint limits and at
   most ``max_joint_step`` from the previous row in every joint are the choices; the objective picks
   one (``nearest``: the least Euclidean step from the previous row; ``margin``, ``manipulability``:
   the largest, :class:`~kinematics.algorithms.ik_self_motion.Objective`), refined by
   :data:`REFINE_ROUNDS` rounds of :data:`REFINE_POINTS` values between its neighbours. Where no
   sample qualifies, damped Newton steps from the previous row (the least-norm step) give ψ, and the
   slice there gives the exact row;
3. where neither does, the path stops: ``unreachable`` (the target's self-motion is empty),
   ``limits`` (none of it lies within the joint limits) or ``joint_jump`` (it does, but no choice
   is within ``max_joint_step`` of the previous row).

With a ``collision_free`` filter the self-motion is used to avoid self-collision: a choice in
self-collision is no choice (the first row: the best free point,
:func:`~kinematics.algorithms.ik_self_motion_free.best_free`), and where the only choices that may
follow collide the path stops with ``collision``. (A 6-joint path cannot choose: it stops at its
first row in self-collision.)

Every row is a slice solution (exact to :data:`~kinematics.algorithms.ik_redundant.TRACK_TOLERANCE`).
"""

from __future__ import annotations

import numpy as np

from ..tolerances import LIMIT_TOLERANCE
from . import ik_self_motion as sm
from .ik import middle_of_limits, pose_errors
from .ik_all import newton
from .ik_path import (DEFAULT_MAX_JOINT_STEP, DEFAULT_STEP_POSITION, DEFAULT_STEP_ROTATION, PathAnswer, path_answer,
                      path_targets)
from .ik_redundant import MATCH, PSI_TOLERANCE, SelfMotion
from .ik_self_motion_free import best_free

#: parameter values solved on each side of the previous row's (the window is ±max_joint_step)
WINDOW = 16
#: rounds of refinement around the best sample, each solving this many values between its neighbours
REFINE_ROUNDS, REFINE_POINTS = 10, 6
#: two solutions of neighbouring values are one branch when no joint moved more than this (rad or m);
#: a cell where the branch moves more is halved, down to MIN_CELL (then the branch ends in it)
SMOOTH, MIN_CELL = 0.1, 1e-9
#: a seed this near (rad or m, every joint) a solution at its own parameter value is the first row
SEED_MATCH = 1e-6
#: margin and manipulability: the choice nearest the previous row among those within this share of the best
SLACK = 1e-3
#: slices one target solves, about (the service's budget counts these)
SLICES_PER_TARGET = 2 * WINDOW + 1 + 2 * REFINE_ROUNDS * REFINE_POINTS + 1


def self_motion_path(motion: SelfMotion, waypoints: np.ndarray, objective: str, seed: np.ndarray | None = None, *,
                     base: np.ndarray | None = None, step_position: float = DEFAULT_STEP_POSITION,
                     step_rotation: float = DEFAULT_STEP_ROTATION, max_joint_step: float = DEFAULT_MAX_JOINT_STEP,
                     collision_free=None) -> PathAnswer:
    """The path of ``motion``'s link through ``waypoints`` (N, 4, 4, world frame; ``base``
    ``T_world_root``), choosing the self-motion for ``objective`` (one of
    :data:`~kinematics.algorithms.ik_redundant.OBJECTIVES`) from ``seed`` (dof,) (see the module text);
    ``collision_free`` as for :func:`~kinematics.algorithms.ik_path.cartesian_path`."""
    targets, length = path_targets(waypoints, base, step_position, step_rotation, max_joint_step)
    model = motion.model
    start = np.array(middle_of_limits(model) if seed is None else seed, dtype=float)
    for name, v in motion.locked.items():
        start[model.q_index[name]] = v
    rows: list[np.ndarray] = []
    stopped = None
    for i, T in enumerate(targets):
        if i == 0:
            q, blocked = _first(motion, T, objective, start, seed is not None, collision_free), True
        else:
            q, blocked = _follow(motion, T, rows[-1], objective, max_joint_step, collision_free)
        if q is None:
            stopped = {"index": i, "reason": _why_none(motion, T, i, blocked and collision_free is not None)}
            break
        rows.append(q)
    return path_answer(motion.poe, motion.link, motion.tool, np.array(rows).reshape(len(rows), model.dof), targets,
                       length, stopped, collision_free, motion.family_name())


def _first(motion: SelfMotion, T: np.ndarray, objective: str, start: np.ndarray, seeded: bool,
           free) -> np.ndarray | None:
    """The first row: the point of the target's whole self-motion nearest the seed (the seed's own slice
    solution where the seed reaches the target inside the limits, free), or best for the objective
    (with ``free``, the best free point: :func:`~kinematics.algorithms.ik_self_motion_free.best_free`)."""
    if seeded:
        win = _Window(motion, T, start, SEED_MATCH, free)
        q = win.nearest(win.solve(np.array([start[motion.column]]))[0], start)
        if q is not None and win.allowed(q):
            return q
    goal = sm.Objective("nearest", start) if seeded or objective == "nearest" else sm.Objective(objective)
    pieces, branches = sm.intervals(motion, T[None])
    found = (sm.best(motion, T[None], goal, pieces, branches) if free is None
             else best_free(motion, T[None], goal, free, pieces, branches))[0]
    if found is None:
        return None
    q = start.copy()
    cols = motion.chain.columns
    q[cols] = found.q[cols]
    return q


def _why_none(motion: SelfMotion, T: np.ndarray, index: int, blocked: bool) -> str:
    """Why no row reaches ``T``: its self-motion is empty, entirely outside the limits, in self-collision
    where it may follow (``blocked``: a choice was refused only for a collision), or out of reach of
    the previous row."""
    pieces, branches = sm.intervals(motion, T[None])
    if not branches[0]:
        return "unreachable"
    if not pieces[0]:
        return "limits"
    return "collision" if blocked else "joint_jump"


class _Window:
    """The slices of one target near the previous row ``prev``: candidates as 2πk copies nearest it, and
    which of them may follow it (inside the limits, no joint moved more than ``max_joint_step``)."""

    def __init__(self, motion: SelfMotion, T: np.ndarray, prev: np.ndarray, max_joint_step: float, free=None):
        self.motion, self.T, self.prev, self.step, self.free = motion, T, prev, max_joint_step, free
        self.blocked = False  # a choice was refused for a collision alone
        self._free: dict[bytes, bool] = {}
        model, chain = motion.model, motion.chain
        self.cols = chain.columns
        self.periodic = chain.revolute.copy()
        self.periodic[motion.k] = False  # the parameter keeps the value it is solved at
        self.lo = model.lower_limits[self.cols] - LIMIT_TOLERANCE
        self.hi = model.upper_limits[self.cols] + LIMIT_TOLERANCE

    def solve(self, psi: np.ndarray) -> list[np.ndarray]:
        """Per value the solutions (K, dof), each revolute joint the copy nearest the previous row."""
        sl = self.motion.solve(np.repeat(self.T[None], len(psi), axis=0), psi, exact=True)
        out = []
        for r in range(len(psi)):
            Q = sl.q[r, :sl.count[r]].copy()
            x = Q[:, self.cols]
            d = x - self.prev[self.cols]
            x = np.where(self.periodic, self.prev[self.cols] + np.mod(d + np.pi, 2 * np.pi) - np.pi, x)
            Q[:] = self.prev
            Q[:, self.cols] = x
            out.append(Q)
        return out

    def distance(self, Q: np.ndarray, q: np.ndarray) -> np.ndarray:
        return np.abs(Q[:, self.cols] - q[self.cols]).max(axis=1) if len(Q) else np.zeros(0)

    def allowed(self, q: np.ndarray) -> bool:
        """``q`` may follow the previous row: inside the limits, within the step and (with a filter) free."""
        x = q[self.cols]
        if not (np.all((x >= self.lo) & (x <= self.hi)) and self.distance(q[None], self.prev)[0] <= self.step):
            return False
        if self.free is None:
            return True
        key = q.tobytes()
        if key not in self._free:
            self._free[key] = bool(self.free(q[None])[0])
            self.blocked |= not self._free[key]
        return self._free[key]

    def score(self, objective: sm.Objective, q: np.ndarray) -> float:
        """``objective`` at ``q`` where ``q`` may follow the previous row, else −∞."""
        return float(objective.values(self.motion, q, self.motion.margins(q))[0]) if self.allowed(q) else -np.inf

    def nearest(self, Q: np.ndarray, q: np.ndarray) -> np.ndarray | None:
        """The solution of ``Q`` on the branch of ``q`` (nearest it, within MATCH), or None."""
        d = self.distance(Q, q)
        if not len(d) or d.min() >= MATCH:
            return None
        return Q[int(np.argmin(d))]

    def bridge(self, p: float, q: np.ndarray, p2: float, Q2: np.ndarray) -> list | None:
        """The branch of ``q`` (at ψ = ``p``) carried to ``p2`` (its solutions ``Q2``): ``[(ψ, q), ...]``
        ending at ``p2``, the cell halved (each half solved) while no solution moved less than
        :data:`SMOOTH` in every joint; None where the branch ends inside the cell."""
        d = self.distance(Q2, q)
        if len(d) and d.min() < SMOOTH:
            return [(p2, Q2[int(np.argmin(d))])]
        if abs(p2 - p) <= MIN_CELL:
            return None
        m = (p + p2) / 2
        left = self.bridge(p, q, m, self.solve(np.array([m]))[0])
        right = None if left is None else self.bridge(m, left[-1][1], p2, Q2)
        return None if right is None else left + right


def _follow(motion: SelfMotion, T: np.ndarray, prev: np.ndarray, objective: str, max_joint_step: float,
            free) -> tuple[np.ndarray | None, bool]:
    """The next row after ``prev`` at ``T`` (see the module text), or None where no continuous choice
    exists; and whether a choice was refused for a collision alone."""
    win = _Window(motion, T, prev, max_joint_step, free)
    psi0 = float(np.clip(prev[motion.column], motion.lower, motion.upper))
    a, b = max(motion.lower, psi0 - max_joint_step), min(motion.upper, psi0 + max_joint_step)
    grid = np.unique(np.concatenate([np.linspace(a, psi0, WINDOW + 1), np.linspace(psi0, b, WINDOW + 1)]))
    sols = win.solve(grid)
    # the branch of the previous row: from the solution nearest it, outwards sample by sample
    near = [win.distance(Q, prev).min(initial=np.inf) for Q in sols]
    j0 = int(np.argmin(near))
    track: dict[float, np.ndarray] = {}
    if near[j0] < MATCH:
        track[float(grid[j0])] = sols[j0][int(np.argmin(win.distance(sols[j0], prev)))]
        for order in (range(j0 + 1, len(grid)), range(j0 - 1, -1, -1)):
            p, q = float(grid[j0]), track[float(grid[j0])]
            for j in order:
                steps = win.bridge(p, q, float(grid[j]), sols[j])
                if steps is None:
                    break
                track.update(steps)
                p, q = steps[-1]
    if not track:
        return _newton_row(win), win.blocked
    # the objective's best choice, then (margin, manipulability) the choice nearest the previous row
    # among those within SLACK of it: no swing along the self-motion for a negligible gain
    nearest, goal = sm.Objective("nearest", prev), sm.Objective(objective)
    best = _refine(win, track, lambda q: win.score(nearest if objective == "nearest" else goal, q))
    if best is None:
        return _newton_row(win), win.blocked
    if objective != "nearest":
        top = win.score(goal, track[best])
        floor = top - SLACK * max(abs(top), 1e-12)
        best = _refine(win, track, lambda q: win.score(nearest, q) if win.score(goal, q) >= floor else -np.inf)
    return track[best], win.blocked


def _refine(win: _Window, track: dict, score) -> float | None:
    """The parameter value of the best ``score`` over the branch ``track`` (ψ -> q; the values solved
    here are added to it): the best sample, then :data:`REFINE_ROUNDS` rounds of :data:`REFINE_POINTS`
    values between its neighbours. None where no sample scores above −∞."""
    known = {p: score(q) for p, q in track.items()}
    best = max(known, key=known.get)
    if not np.isfinite(known[best]):
        return None
    for _ in range(REFINE_ROUNDS):
        ps = sorted(known)
        i = ps.index(best)
        lo, hi = ps[max(i - 1, 0)], ps[min(i + 1, len(ps) - 1)]
        if hi - lo <= PSI_TOLERANCE:
            break
        psi = np.linspace(lo, hi, REFINE_POINTS + 2)[1:-1]
        for p, Q in zip(psi.tolist(), win.solve(psi)):
            ref = min(track, key=lambda k: abs(k - p))
            for x, q in win.bridge(ref, track[ref], p, Q) or ():
                track[x] = q
                known[x] = score(q)
        best = max(known, key=known.get)
    return best


def _newton_row(win: _Window) -> np.ndarray | None:
    """The row of the least-norm step from the previous row (damped Newton on the whole chain), made
    exact on its slice; None where it fails or may not follow."""
    motion, prev = win.motion, win.prev
    q = newton(motion.poe, motion.link, prev[None], win.T[None], win.cols, 40, motion.tool, damped=True)[0]
    p, r = pose_errors(motion.poe.fk(q[None], [motion.link], tool=motion.tool)[:, 0], win.T[None])
    if not (p[0] <= motion.tolerances["position_tolerance"] and r[0] <= motion.tolerances["rotation_tolerance"]):
        return None
    psi = float(np.clip(q[motion.column], motion.lower, motion.upper))
    q = win.nearest(win.solve(np.array([psi]))[0], q)
    return q if q is not None and win.allowed(q) else None
