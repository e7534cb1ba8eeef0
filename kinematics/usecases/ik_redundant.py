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

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..algorithms import ik as _ik
from ..algorithms import ik_redundant as red
from ..algorithms import ik_self_motion as sm
from ..errors import BudgetError, KinematicsError
from ..spatial.transforms import inverse_transform
from .ik_all import IKAllAnswer
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


def ik_redundant(query: Query | Any, target: Any, *, redundancy: Any, seed: Any = None, locked: dict | None = None,
                 limits: str = "respect", mode: str = "pose",
                 position_tolerance: float = _ik.DEFAULT_POSITION_TOLERANCE,
                 rotation_tolerance: float = _ik.DEFAULT_ROTATION_TOLERANCE, **options: Any) -> IKRedundantAnswer:
    """Every solution of the query's redundant chain at ``target`` (one pose or a list), along the
    self-motion as ``redundancy`` (:class:`~kinematics.algorithms.ik_redundant.Redundancy` or its map
    ``{parameter, values, intervals, select}``) asks: with ``values`` every solution at each value
    (``limits`` as for every solution: ``respect`` lists only in-limit ones, a value outside the
    parameter joint's limits gives none); with ``select`` the one best in-limit solution of each
    target over the whole self-motion (``count`` 0 where none is in the limits); with ``intervals``
    the in-limit ranges. The query's ``budget.max_batch`` bounds the (target, value) pairs."""
    spec = red.Redundancy.of(redundancy)
    query = Query.of(query, **options)
    if mode != "pose":
        raise KinematicsError("redundancy: a redundant chain's self-motion is of a pose (mode 'pose')")
    if query.floating_base:
        raise KinematicsError("floating_base: every IK solution needs a fixed base (give the base pose as base)")
    model = query.robot
    T, is_batch = query.targets(target)
    N = T.shape[0]
    link = query.frame_link()
    seeds = query.seeds(seed, N)
    motion = red.SelfMotion(model, link, spec.parameter, locked=locked, tool=query.T_tool,
                            seed=None if seeds is None else seeds[0],
                            position_tolerance=position_tolerance, rotation_tolerance=rotation_tolerance)
    B = query.base_poses(N)
    T_root = T if B is None else np.matmul(inverse_transform(B), T)
    pieces = branches = None
    if spec.intervals or spec.select:
        pieces, branches = sm.intervals(motion, T_root)
    intervals = [sm.merged(p) for p in pieces] if spec.intervals else None
    if spec.select:
        goal = sm.Objective(spec.select, _seed(model, seeds) if spec.select == "nearest" else None)
        found = sm.best(motion, T_root, goal, pieces, branches)
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
        family = family or motion.family_name()
    else:
        arrays = _one_each(motion, T_root, [None] * N, model.dof)
        family, method = motion.family_name(), "analytic"
    q, param, count, within, singular, pe, re, complete = arrays
    return IKRedundantAnswer(q, count, within, singular, pe, re, complete, model=model, link=link, mode=mode,
                             is_batch=is_batch, targets=T, family=family, method=method, locked=dict(motion.locked),
                             parameter=param, parameter_name=motion.joint, intervals=intervals, select=spec.select)


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
