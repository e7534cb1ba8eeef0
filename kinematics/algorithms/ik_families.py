"""Which closed form solves a chain: its family, read from the model's own zero-configuration screws.

:func:`reduce_chain` takes the moving joints on the path from the root to a link (the
:class:`~kinematics.engine.poe.PoEModel` screws ``S_j``, written as unit axes ``h_j`` and a point
``r_j`` on each revolute axis, and the link's home pose ``M``) and folds the ``locked`` joints in:
``E_j(v)`` is pushed to the right through the later exponentials (each later axis and point moved
by the rigid motion ``E_j(v)``, and ``M ← E_j(v) M``), so a 7-dof arm with one locked joint is an
ordinary 6-joint chain.

:func:`detect` names the family of a 6-joint chain: it tests which axes meet in a point
(a spherical wrist: axes 4, 5, 6), which are parallel (UR's 2 ∥ 3 ∥ 4), which joints are
prismatic, forwards and on the **reversed** chain (``T⁻¹ = E'6(−q6) ... E'1(−q1) M⁻¹`` with
``S'_j = Ad_{M⁻¹} S_j``: a spherical shoulder is a reversed spherical wrist). A chain whose axes
are within ``NEAR_ANGLE`` / ``NEAR_DISTANCE`` of a family (a calibrated robot, a URDF with rounded
origins) is **near** that family: its ``ideal`` chain is the projection onto the family (meeting
axes moved to their least-squares common point, parallel axes given their mean direction) and
the closed form of the ideal chain seeds Newton steps on the real one.

>>> from kinematics.io import default_catalogue
>>> fam = detect(reduce_chain(default_catalogue().get("ur5"), "tool0"))
>>> fam.name, fam.closed_form, fam.max_solutions
('three_parallel', True, 8)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from ..engine import ik_fast
from ..engine.compiled import PRISMATIC
from ..engine.poe import PoEModel, compile_model
from ..errors import KinematicsError, LockedJointError, did_you_mean
from ..model.robot import RobotModel
from ..spatial.transforms import cross3, exp_screws, inverse_transform
from ..tolerances import LIMIT_TOLERANCE
from . import ik_general

#: an exact family: axes parallel / meeting within these (radians, metres)
EXACT_ANGLE, EXACT_DISTANCE = 1e-9, 1e-9
#: a near family (solved by the ideal chain's closed form, then Newton on the real one)
NEAR_ANGLE, NEAR_DISTANCE = 2e-2, 1e-2


@dataclass(frozen=True, eq=False)
class Chain:
    """The free joints from the root to a link, locked joints folded in.

    joints: names of the free joints, root first; columns: their columns of q (n,);
    revolute: (n,) bool; h: (n, 3) unit axes (prismatic: directions) and r: (n, 3) points on the
    revolute axes, world frame at q = 0; M: (4, 4) home pose of the link (times the tool);
    locked: the locked values; columns_locked: their columns of q; mimic: a mimic joint on the path
    (no closed form then).
    """

    link: str
    joints: tuple[str, ...]
    columns: np.ndarray
    revolute: np.ndarray
    h: np.ndarray
    r: np.ndarray
    M: np.ndarray
    locked: dict = field(default_factory=dict)
    columns_locked: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    mimic: bool = False

    @property
    def n(self) -> int:
        return len(self.joints)

    def reversed(self) -> "Chain":
        """The chain of ``T⁻¹``: axes ``Ad_{M⁻¹}`` of joints n ... 1, home ``M⁻¹`` (joint values negated)."""
        X = inverse_transform(self.M)
        h = (self.h[::-1] @ X[:3, :3].T)
        r = self.r[::-1] @ X[:3, :3].T + X[:3, 3]
        return replace(self, joints=self.joints[::-1], columns=self.columns[::-1], revolute=self.revolute[::-1],
                       h=h, r=r, M=X)


def validate_locked(model: RobotModel, locked: dict | None) -> dict[str, float]:
    """``locked`` as ``{joint: value}`` floats; an unknown joint or a value outside the limits raises
    :class:`LockedJointError` naming it."""
    out: dict[str, float] = {}
    for name, value in (locked or {}).items():
        if name not in model.q_index:
            raise LockedJointError(f"locked: {name!r} is not a joint of {model.name}"
                                   f"{did_you_mean(name, model.joint_names, 'joints')}", joint=str(name))
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise LockedJointError(f"locked.{name}: {value!r} is not a number", joint=name) from None
        if not np.isfinite(v):
            raise LockedJointError(f"locked.{name}: {value!r} is not finite", joint=name)
        i = model.q_index[name]
        lo, hi = model.lower_limits[i], model.upper_limits[i]
        if v < lo - LIMIT_TOLERANCE or v > hi + LIMIT_TOLERANCE:
            raise LockedJointError(f"locked.{name}: {v!r} is outside the joint's limits [{lo:g}, {hi:g}]", joint=name)
        out[name] = v
    return out


def reduce_chain(model: RobotModel, link: str, locked: dict | None = None, tool: np.ndarray | None = None) -> Chain:
    """The free chain from the root to ``link`` (``tool``: ``T_link_tool``), ``locked`` joints folded in."""
    locked = validate_locked(model, locked)
    if model.multi_dof:
        raise KinematicsError("every IK solution needs a model of one-degree-of-freedom joints "
                              "(floating or planar joints: use solutions 'one')")
    poe = compile_model(model)
    assert isinstance(poe, PoEModel)
    li = int(poe.link_indices([link])[0])
    path = np.flatnonzero(poe.path_mask(li))
    M = poe.M[li] @ (np.eye(4) if tool is None else np.asarray(tool, dtype=float))
    mimic = bool(np.any(poe.multiplier[path] != 1.0) or np.any(poe.offset[path] != 0.0)
                 or len(set(poe.q_index[path].tolist())) != len(path))
    names = [poe.joint_names[j] for j in path]
    h = [poe.w[j].copy() for j in path]
    r = [poe.r[j].copy() for j in path]
    rev = [bool(poe.kind[j] != PRISMATIC) for j in path]
    cols = [int(poe.q_index[j]) for j in path]
    for k in range(len(names) - 1, -1, -1):
        name = names[k]
        if name not in locked:
            continue
        E = exp_screws(np.array([h[k]]), np.array([r[k]]), np.array([rev[k]]), np.array([locked[name]]))[0]
        for m in range(k + 1, len(names)):
            h[m] = E[:3, :3] @ h[m]
            r[m] = E[:3, :3] @ r[m] + E[:3, 3]
        M = E @ M
        for seq in (names, h, r, rev, cols):
            del seq[k]
    n = len(names)
    return Chain(link=link, joints=tuple(names), columns=np.array(cols, dtype=np.intp), revolute=np.array(rev, bool),
                 h=np.array(h, float).reshape(n, 3), r=np.array(r, float).reshape(n, 3), M=M, locked=locked,
                 columns_locked=np.array([model.q_index[j] for j in locked], dtype=np.intp), mimic=mimic)


# ---------------------------------------------------------------------- geometry of axes
def _angle(a: np.ndarray, b: np.ndarray) -> float:
    """The angle between the lines of directions a, b (0 when parallel or antiparallel)."""
    c = cross3(a, b)
    return math.asin(min(1.0, math.sqrt(float(c @ c))))


def _common_point(h: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, float]:
    """The least-squares common point of the lines (r_i, h_i) and its largest distance to them:
    ``Σ (I − h_i h_iᵀ) c = Σ (I − h_i h_iᵀ) r_i``."""
    h, r = np.asarray(h, dtype=float), np.asarray(r, dtype=float)
    A = len(h) * np.eye(3) - h.T @ h
    b = r.sum(axis=0) - h.T @ np.sum(h * r, axis=1)
    c = np.linalg.lstsq(A, b, rcond=None)[0]
    e = c - r
    e = e - h * np.sum(h * e, axis=1)[:, None]
    return c, float(np.sqrt(np.max(np.sum(e * e, axis=1))))


def _meet(ch: Chain, idx, angle_min: float) -> tuple[np.ndarray, float] | None:
    """Common point of the revolute axes ``idx`` (consecutive ones not parallel) and its distance, or None."""
    if not all(ch.revolute[i] for i in idx):
        return None
    for a in range(len(idx) - 1):  # consecutive axes not parallel (4 ∥ 6 is the wrist at q5 = 0)
        if _angle(ch.h[idx[a]], ch.h[idx[a + 1]]) < angle_min:
            return None
    return _common_point(ch.h[list(idx)], ch.r[list(idx)])


def _parallel(ch: Chain, idx) -> float | None:
    """The largest angle between the revolute axes ``idx`` and the first (None if one is prismatic)."""
    if not all(ch.revolute[i] for i in idx):
        return None
    return max(_angle(ch.h[idx[0]], ch.h[i]) for i in idx[1:])


def _mean_direction(ch: Chain, idx) -> dict[int, np.ndarray]:
    ref = ch.h[idx[0]]
    s = sum(np.sign(ref @ ch.h[i]) * ch.h[i] for i in idx)
    s = s / np.linalg.norm(s)
    return {i: np.sign(ref @ ch.h[i]) * s for i in idx}


# ---------------------------------------------------------------------- families
@dataclass(frozen=True, eq=False)
class Family:
    """A chain's family: ``name``, the ``subproblems`` its closed form uses, ``closed_form``,
    ``max_solutions`` (None: not bounded by the structure), ``reversed`` (solved on the reversed
    chain), ``near`` (the chain is within the near tolerances, not exactly of the family), ``deviation``
    (the largest angle/distance from the exact family), ``ideal`` (the chain the closed form runs on),
    ``kernel`` and ``position`` (which compiled kernel), ``centre`` (the wrist centre of ``ideal``).

    Chains of fewer than six joints are ``planar`` (every axis parallel: 2R, 3R, SCARA; in closed
    form for two or three revolute joints and at most one prismatic), ``rpr`` (closed form) or
    ``short_chain`` (the multistart search); a slide followed by three parallel axes between two
    others (Wen's Rhino arm) is ``prismatic_three_parallel`` (closed form, :mod:`.ik_general`); a 6R
    chain with none of the families above is ``general_6r``, solved by the 16-degree elimination of
    :mod:`kinematics.algorithms.ik_general` (``general``: a 6-joint chain with a prismatic joint and
    no family, the multistart search)."""

    name: str
    subproblems: tuple[int, ...]
    closed_form: bool
    max_solutions: int | None
    chain: Chain
    ideal: Chain | None = None
    reversed: bool = False
    near: bool = False
    deviation: float = 0.0
    kernel: str = ""
    position: int = -1
    centre: np.ndarray | None = None

    def as_dict(self) -> dict:
        return {"family": self.name, "closed_form": self.closed_form, "max_solutions": self.max_solutions,
                "subproblems": list(self.subproblems), "reversed": self.reversed, "near": self.near}


_WRIST_POSITIONS = {
    ik_fast.POS_PARALLEL_23: ("parallel_23", (4, 3, 1)),
    ik_fast.POS_INTERSECT_12: ("intersecting_12", (3, 2)),
    ik_fast.POS_INTERSECT_12_PRISMATIC: ("intersecting_12_prismatic", (2,)),
    ik_fast.POS_PARALLEL_12: ("parallel_12", (4, 3, 1)),
}


def _try_forward(ch: Chain, angle: float, distance: float) -> Family | None:
    """The family of ``ch`` as it stands (not reversed) within the tolerances, or None."""
    if ch.n != 6:
        return None
    wrist = _meet(ch, (3, 4, 5), max(angle, 1e-3))
    if wrist is not None and wrist[1] <= distance:
        c, dev = wrist
        h, r = ch.h.copy(), ch.r.copy()
        r[3:6] = c
        devs = [dev]
        position = None
        par23 = _parallel(ch, (1, 2))
        meet12 = None
        if ch.revolute[0] and ch.revolute[1]:
            meet12 = _meet(ch, (0, 1), max(angle, 1e-3))
        par12 = _parallel(ch, (0, 1))
        if ch.revolute[0] and par23 is not None and par23 <= angle and _angle(ch.h[0], ch.h[1]) > 1e-3:
            position = ik_fast.POS_PARALLEL_23
            for i, v in _mean_direction(ch, (1, 2)).items():
                h[i] = v
            devs.append(par23)
        elif meet12 is not None and meet12[1] <= distance:
            position = ik_fast.POS_INTERSECT_12 if ch.revolute[2] else ik_fast.POS_INTERSECT_12_PRISMATIC
            r[0:2] = meet12[0]
            devs.append(meet12[1])
        elif par12 is not None and par12 <= angle and ch.revolute[2] and _angle(ch.h[0], ch.h[2]) > 1e-3:
            position = ik_fast.POS_PARALLEL_12
            for i, v in _mean_direction(ch, (0, 1)).items():
                h[i] = v
            devs.append(par12)
        if position is None and ch.revolute[0] and ch.revolute[1] and ch.revolute[2]:
            position = ik_fast.POS_SEARCH  # a general 3R positioning arm: the search over q1
        if position == ik_fast.POS_SEARCH:
            # a general 3R positioning arm: the 16-degree elimination of the whole chain (every solution,
            # on the chain itself, so a near wrist needs no projection), else the bracketing search over q1
            if ik_general.applies(ch):
                return Family("spherical_wrist_general", (1,), True, 8, ch, ch, deviation=max(devs),
                              kernel="general_6r", centre=c)
            ideal = replace(ch, h=h, r=r)
            return Family("spherical_wrist_general", (3, 1, 2), False, 8, ch, ideal, deviation=max(devs),
                          kernel="spherical_wrist_search", position=position, centre=c)
        if position is not None:
            name, subs = _WRIST_POSITIONS[position]
            ideal = replace(ch, h=h, r=r)
            return Family(f"spherical_wrist_{name}", tuple(sorted(set(subs + (2, 1)))), True, 8, ch, ideal,
                          deviation=max(devs), kernel="spherical_wrist", position=position, centre=c)
    par = _parallel(ch, (1, 2, 3))
    if par is not None and par <= angle and ch.revolute[0] and _angle(ch.h[0], ch.h[1]) > 1e-3:
        meet56 = _meet(ch, (4, 5), max(angle, 1e-3))
        if meet56 is not None and meet56[1] <= distance:
            h, r = ch.h.copy(), ch.r.copy()
            for i, v in _mean_direction(ch, (1, 2, 3)).items():
                h[i] = v
            r[4:6] = meet56[0]
            ideal = replace(ch, h=h, r=r)
            return Family("three_parallel", (4, 1, 3), True, 8, ch, ideal, deviation=max(par, meet56[1]),
                          kernel="three_parallel", centre=meet56[0])
    return None


def _mimic(ch: Chain) -> Family | None:
    return Family("mimic", (), False, None, ch) if ch.mimic else None


def _redundant(ch: Chain) -> Family | None:
    return Family("redundant", (), False, None, ch) if ch.n > 6 else None


#: the kernels of a closed form by subproblems alone (fast); a chain near one of them is read as near it
#: rather than exactly as a spherical wrist on a general arm (the elimination or the search)
SUBPROBLEM_KERNELS = ("spherical_wrist", "three_parallel")


def _subproblem_family(ch: Chain) -> Family | None:
    """The subproblem families of a 6-joint chain (exact first, then near; forwards first, then reversed).
    A closed form by subproblems alone comes first: a spherical wrist whose arm is within the near
    tolerances of an intersecting or parallel pair (a URDF's rounded shoulder, a calibrated arm) is
    that near family, not ``spherical_wrist_general`` (the elimination of the whole chain)."""
    if ch.n != 6:
        return None
    first = None
    for angle, distance, near in ((EXACT_ANGLE, EXACT_DISTANCE, False), (NEAR_ANGLE, NEAR_DISTANCE, True)):
        for rev in (False, True):
            fam = _try_forward(ch.reversed() if rev else ch, angle, distance)
            if fam is None:
                continue
            if rev:
                name = fam.name.replace("spherical_wrist", "spherical_shoulder") if fam.kernel == "spherical_wrist" \
                    else fam.name + "_reversed"
                fam = replace(fam, name=name, chain=ch, reversed=True)
            fam = replace(fam, near=near)
            if fam.kernel in SUBPROBLEM_KERNELS:
                return fam
            first = first or fam
    return first


def _short_chain(ch: Chain) -> Family | None:
    """A chain of fewer than six joints: planar when every axis is parallel to the first revolute one
    (2R, 3R, SCARA), ``rpr``, else ``short_chain`` (the search)."""
    if not 0 < ch.n < 6:
        return None
    kernel = ik_general.short_kernel(ch)
    if kernel == "rpr":
        return Family("rpr", (1,), True, 1, ch, ch, kernel=kernel)
    rev = np.flatnonzero(ch.revolute)
    ref = ch.h[rev[0]] if rev.size else ch.h[0]
    if all(_angle(ref, h) < EXACT_ANGLE for h in ch.h):
        return Family("planar", (3, 1) if kernel else (), bool(kernel), 2 if rev.size >= 2 else 1, ch,
                      ch if kernel else None, kernel=kernel)
    return Family("short_chain", (), False, None, ch)


def _prismatic_three_parallel(ch: Chain) -> Family | None:
    """A slide, then three parallel axes between two others (Wen's Rhino arm): closed form."""
    if ch.n != 6:
        return None
    for c, rev in ((ch, False), (ch.reversed(), True)):
        if ik_general.prismatic_parallel(c):
            return Family("prismatic_three_parallel" + ("_reversed" if rev else ""), (2, 1, 3, 1), True, 4, ch,
                          c, reversed=rev, kernel="prismatic_three_parallel")
    return None


def _general_6r(ch: Chain) -> Family | None:
    """Every solution by the 16-degree Raghavan-Roth elimination (an eigenvalue problem), on the chain
    or, where its geometry makes the elimination degenerate, on the reversed chain, or on a cyclic
    shift of the loop per target (degenerate both ways: a Jaco-like wrist)."""
    if ch.n != 6:
        return None
    if ik_general.usable(ch):
        return Family("general_6r", (1,), True, 16, ch, ch, kernel="general_6r")
    rch = ch.reversed()
    if ik_general.usable(rch):
        return Family("general_6r", (1,), True, 16, ch, rch, reversed=True, kernel="general_6r")
    if ik_general.usable(ch, shifts=True):
        return Family("general_6r", (1,), True, 16, ch, ch, kernel="general_6r")
    return None


#: the family detectors, tried in order by :func:`detect`: ``(name, detector(chain) -> Family | None)``;
#: a chain none of them claims is ``general`` (the multistart search)
DETECTORS: list[tuple[str, Callable[[Chain], Family | None]]] = [
    ("mimic", _mimic),
    ("redundant", _redundant),
    ("subproblems", _subproblem_family),
    ("short_chain", _short_chain),
    ("prismatic_three_parallel", _prismatic_three_parallel),
    ("general_6r", _general_6r),
]


def register_family(name: str, detector: Callable[[Chain], Family | None], before: str | None = None) -> None:
    """Add a family's ``detector`` to :data:`DETECTORS` (before the one named ``before``; None: last).
    Its families name their kernel (:mod:`kinematics.algorithms.ik_kernels`)."""
    names = [n for n, _ in DETECTORS]
    DETECTORS.insert(names.index(before) if before is not None else len(DETECTORS), (name, detector))


def detect(ch: Chain) -> Family:
    """The family of the chain ``ch``: the first of :data:`DETECTORS` that claims it, else ``general``."""
    for _, detector in DETECTORS:
        fam = detector(ch)
        if fam is not None:
            return fam
    return Family("general", (), False, 16 if ch.n == 6 else None, ch)
