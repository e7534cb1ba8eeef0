"""Every solution of a redundant (7-joint) chain: slices of its self-motion at given parameter values,
the in-limit intervals of the parameter, the best point (:mod:`kinematics.algorithms.ik_redundant`,
:mod:`kinematics.algorithms.ik_self_motion`).

>>> import numpy as np
>>> from kinematics.io import default_catalogue
>>> from kinematics.usecases.fk import fk
>>> panda = default_catalogue().get("panda")
>>> q = np.array([0.3, -0.5, 0.2, -2.0, 0.4, 1.8, 0.7, 0.0])
>>> T = fk(panda, q, links=["panda_link8"]).poses[0, 0]
>>> a = ik_redundant(Query(panda, link="panda_link8"), T, redundancy={"values": [0.7, 1.0]})
>>> a.parameter_name, int(a.count[0]) > 0, bool(np.nanmax(a.position_error) < 1e-9)
('panda_joint7', True, True)
>>> sorted(set(a.parameter[0, :a.count[0]].tolist()))
[0.7, 1.0]
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..algorithms import ik as _ik
from ..algorithms.ik import IKSolution
from ..algorithms.ik_all import NEAR_STEPS
from ..algorithms import ik_redundant as red
from ..algorithms import ik_self_motion as sm
from ..algorithms.ik_self_motion_free import best_free
from ..errors import BudgetError, KinematicsError
from ..spatial.transforms import inverse_transform
from .ik_all import IKAllAnswer
from .ik_options import IKOptions
from .ik_select import IKProblem, first_of_each
from .query import Query


@dataclass(frozen=True, eq=False)
class IKRedundantAnswer(IKAllAnswer):
    """An :class:`~kinematics.usecases.ik_all.IKAllAnswer` of a redundant chain: ``parameter`` (N, K) the
    parameter value of each solution (NaN in padding), ``parameter_name`` (its joint), ``intervals``
    (per target the in-limit ranges, or None), ``select`` (the objective, or None: then ``solutions``
    are the slices at the request's values)."""

    parameter: np.ndarray | None = None
    parameter_name: str = ""
    intervals: list | None = None
    select: str | None = None

    def solutions(self, n: int = 0) -> list[dict[str, Any]]:
        out = super().solutions(n)
        for k, s in enumerate(out):
            s["parameter"] = float(self.parameter[n, k])
        return out


def ik_redundant(query: Query | Any, target: Any, *, seed: Any = None, options: IKOptions | None = None,
                 **keywords: Any) -> IKRedundantAnswer:
    """Every solution of the query's redundant chain at ``target`` (one pose or a list), along the
    self-motion as the options' ``redundancy`` (:class:`~kinematics.algorithms.ik_redundant.Redundancy`
    or its map ``{parameter, values, intervals, select}``; :class:`~kinematics.usecases.ik_options.IKOptions`
    or its keywords, :meth:`IKOptions.split`) asks: with ``values`` every solution at each value
    (``limits`` as for every solution: ``respect`` lists only in-limit ones, a value outside the
    parameter joint's limits gives none); with ``select`` the one best in-limit solution of each
    target over the whole self-motion (``count`` 0 where none is in the limits); with ``intervals``
    the in-limit ranges. The query's ``budget.max_batch`` bounds the (target, value) pairs.

    ``avoid_collisions``: with ``values`` the colliding solutions are left out (counted in
    ``colliding``); with ``select`` the best point free of self-collision
    (:func:`~kinematics.algorithms.ik_self_motion_free.best_free`); ``intervals`` do not look at
    collisions and are refused with it."""
    options, rest = IKOptions.split(options, keywords)
    wanted, settings = options.solutions, options.settings
    spec = red.Redundancy.of(wanted.redundancy)
    query = Query.of(query, **rest)
    if settings.mode != "pose":
        raise KinematicsError("redundancy: a redundant chain's self-motion is of a pose (mode 'pose')")
    if query.floating_base:
        raise KinematicsError("floating_base: every IK solution needs a fixed base (give the base pose as base)")
    if options.collisions is not None and spec.intervals:
        raise KinematicsError("avoid_collisions: the intervals of the self-motion are those of the joint limits "
                              "(collisions are not looked at); ask values or select with avoid_collisions")
    model = query.robot
    free = options.collisions.filter(model, query.collision_pairs) if options.collisions is not None else None
    T, is_batch = query.targets(target)
    N = T.shape[0]
    link = query.frame_link()
    seeds = query.seeds(seed, N)
    limits = wanted.solution_limits
    motion = red.SelfMotion(model, link, spec.parameter, locked=wanted.locked_map, tool=query.T_tool,
                            seed=None if seeds is None else seeds[0],
                            position_tolerance=settings.position_tolerance,
                            rotation_tolerance=settings.rotation_tolerance)
    B = query.base_poses(N)
    T_root = T if B is None else np.matmul(inverse_transform(B), T)
    pieces = branches = colliding = None
    if spec.intervals or spec.select:
        pieces, branches = sm.intervals(motion, T_root)
    intervals = [sm.merged(p) for p in pieces] if spec.intervals else None
    if spec.select:
        goal = sm.Objective(spec.select, _seed(model, seeds) if spec.select == "nearest" else None)
        found = (sm.best(motion, T_root, goal, pieces, branches) if free is None
                 else best_free(motion, T_root, goal, free, pieces, branches))
        arrays = _one_each(motion, T_root, found, model.dof)
        family, method = motion.family_name(), "analytic"
    elif spec.values is not None:
        V = red.check_values(motion, spec.values, N, limits)
        limit = query.budget.max_batch
        if limit is not None and V.size > limit:
            raise BudgetError(f"redundancy.values: {V.size} (target, value) pairs; the limit is {limit}",
                              budget="batch", field="redundancy.values", limit=limit)
        q, param, count, within, singular, pe, re, complete, family, method = red.slices(motion, T_root, V, limits)
        arrays = (q, param, count, within, singular, pe, re, complete)
        if free is not None:
            arrays, colliding = _leave_out(arrays, free)
        family = family or motion.family_name()
    else:
        arrays = _one_each(motion, T_root, [None] * N, model.dof)
        family, method = motion.family_name(), "analytic"
    q, param, count, within, singular, pe, re, complete = arrays
    return IKRedundantAnswer(q, count, within, singular, pe, re, complete, model=model, link=link,
                             mode=settings.mode, is_batch=is_batch, targets=T, family=family, method=method,
                             locked=dict(motion.locked), colliding=colliding, parameter=param,
                             parameter_name=motion.joint, intervals=intervals, select=spec.select)


@dataclass(frozen=True)
class BestOverSelfMotion:
    """A :class:`~kinematics.usecases.ik_select.Selection`: one answer per target, the best solution
    over a redundant (7-joint) chain's whole self-motion by ``objective`` (``nearest`` the seed,
    ``margin`` to the joint limits, ``manipulability``; the ``parameter`` joint, None: the chain's
    default) -- :func:`ik_redundant` with ``select`` (with collision avoidance, the best free point);
    where no in-limit point exists, the numerical answer, without success. What
    ``ik(..., solutions="one", redundancy={"select": ...})`` takes.

    >>> from kinematics.io import default_catalogue
    >>> from kinematics.usecases.fk import fk
    >>> from kinematics.usecases.ik import ik
    >>> panda = default_catalogue().get("panda")
    >>> T = fk(panda, [0.3, -0.5, 0.2, -2.0, 0.4, 1.8, 0.7, 0.0], links=["panda_link8"]).poses[0, 0]
    >>> one = ik(panda, T, link="panda_link8", select=BestOverSelfMotion("margin"))
    >>> bool(one.solution.success[0]), bool(one.solution.position_error[0] < 1e-9)
    (True, True)
    """

    objective: str = "nearest"
    parameter: str | None = None
    #: not a full set of a 6-joint chain (IKProblem.of checks that set's size): the self-motion's own bounds
    full_set: ClassVar[bool] = False

    def work(self, model, link: str, options: IKOptions, family=None) -> tuple[int, int]:
        return 15, NEAR_STEPS  # a closed form's candidates polished, as a full set's (per slice looked at)

    def select(self, problem: IKProblem) -> tuple[IKSolution, np.ndarray | None]:
        spec = red.Redundancy(parameter=self.parameter, select=self.objective)
        options = dataclasses.replace(problem.options, solutions=dataclasses.replace(
            problem.options.solutions, solutions="all", redundancy=spec))
        best = ik_redundant(problem.query, problem.T, seed=problem.seeds, options=options)
        return first_of_each(problem, best, problem.start)


def _leave_out(arrays, free):
    """The padded slices ``arrays`` (q, parameter, count, within, singular, position_error, rotation_error,
    complete) without their solutions in self-collision, and how many each target lost (N,)."""
    q, param, count, within, singular, pe, re, complete = arrays
    listed = np.arange(q.shape[1])[None, :] < count[:, None]
    keep = listed.copy()
    if listed.any():
        keep[listed] = np.asarray(free(q[listed]), dtype=bool)
    order = np.argsort(~keep, axis=1, kind="stable")  # the kept ones first, in their order
    kept = keep.sum(axis=1)
    take = lambda a: np.take_along_axis(a, order[..., None] if a.ndim == 3 else order, axis=1)  # noqa: E731
    q, param, within, singular, pe, re = (take(a) for a in (q, param, within, singular, pe, re))
    gone = np.arange(q.shape[1])[None, :] >= kept[:, None]
    q[gone], param[gone], pe[gone], re[gone] = np.nan, np.nan, np.nan, np.nan
    within[gone] = singular[gone] = False
    return (q, param, kept.astype(np.int64), within, singular, pe, re, complete), (count - kept).astype(np.int64)


def _seed(model, seeds) -> np.ndarray:
    return seeds[0] if seeds is not None else _ik.middle_of_limits(model)


def _one_each(motion, T_root, found, dof):
    """The padded arrays of one best solution per target (or none)."""
    N = len(found)
    K = 1 if any(b is not None for b in found) else 0
    q = np.full((N, K, dof), np.nan)
    param = np.full((N, K), np.nan)
    count = np.array([b is not None for b in found], dtype=np.int64)
    within = np.zeros((N, K), bool)
    singular = np.zeros((N, K), bool)
    pe, re = np.full((N, K), np.nan), np.full((N, K), np.nan)
    for n, b in enumerate(found):
        if b is None:
            continue
        q[n, 0], param[n, 0] = b.q, b.parameter
        within[n, 0] = True
        F = motion.poe.fk(b.q[None], [motion.link], tool=motion.tool)[:, 0]
        p, r = _ik.pose_errors(F, T_root[n:n + 1])
        pe[n, 0], re[n, 0] = p[0], r[0]
        J = motion.poe.jacobian(b.q[None], motion.link, "local_world_aligned", tool=motion.tool)[0][:, motion.chain.columns]
        s = np.linalg.svd(J, compute_uv=False)
        singular[n, 0] = s[-1] <= red.SINGULAR * s[0]
    return q, param, count, within, singular, pe, re, np.ones(N, bool)
