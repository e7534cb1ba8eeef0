"""Collision-free IK: the solutions of :mod:`kinematics.algorithms.ik_all` that are free of
self-collision, and the filter that decides it.

``free`` is a function of configurations (R, dof) -> (R,) bool (True: free of self-collision),
e.g. :func:`kinematics.algorithms.self_collision.collision_free` bound to a model and its
allowed-collision matrix (:func:`self_collision_filter`). :func:`free_solutions` keeps, per
target, the solutions ``free`` accepts, in their order (nearest the seed first stays first),
and counts those it left out.

Of the 2R arm's two solutions of a target, keep those with a positive elbow:

>>> import numpy as np
>>> from kinematics.io import default_catalogue
>>> from kinematics.engine.poe import compile_model
>>> from kinematics.algorithms.ik_all import all_solutions
>>> planar = default_catalogue().get("planar_2r")
>>> T = compile_model(planar).fk(np.array([[0.3, 0.9]]), ["tool"])[:, 0]
>>> sol = all_solutions(planar, "tool", T, mode="position", limits="ignore")
>>> kept, dropped = free_solutions(sol, lambda Q: Q[:, 1] > 0)
>>> int(sol.count[0]), int(kept.count[0]), int(dropped[0]), kept.q[0, 0].round(6).tolist()
(2, 1, 1, [0.3, 0.9])
"""

from __future__ import annotations

import dataclasses
import os
from typing import Callable

import numpy as np

from ..model.robot import RobotModel
from .collision_matrix import DEFAULT_SAMPLES, UserPairs
from .ik_all import AllSolutions

Filter = Callable[[np.ndarray], np.ndarray]


def self_collision_filter(model: RobotModel, *, samples: int = DEFAULT_SAMPLES, margin: float = 0.0,
                          cache_dir: os.PathLike | str | None = None, user_pairs: UserPairs | None = None) -> Filter:
    """``free(Q)`` (R, dof) -> (R,) bool: free of self-collision on the enabled pairs of the model's
    allowed-collision matrix (``samples`` configurations, kept in ``cache_dir``; with the pairs a
    user allows and forbids, ``user_pairs``); closer than
    ``margin`` (m) counts as colliding. Configurations that differ by whole turns of revolute joints
    (the ``q + 2πk`` copies of an IK branch) are one pose of the arm: each is checked once."""
    from . import self_collision as _sc

    _sc.matrix(model, samples, cache_dir=cache_dir, user_pairs=user_pairs)  # the pairs' names checked now
    angular = np.asarray(model.angular, dtype=bool)

    def free(Q: np.ndarray) -> np.ndarray:
        Q = np.asarray(Q, dtype=float).reshape(-1, model.dof)
        if len(Q) == 0:
            return np.zeros(0, bool)
        W = Q.copy()
        W[:, angular] = np.mod(W[:, angular] + np.pi, 2 * np.pi)
        keys = np.round(W, 9)
        keys[:, angular] = np.mod(keys[:, angular], np.round(2 * np.pi, 9))  # 0 and 2π the same
        _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
        return _sc.collision_free(model, Q[first], margin=margin, samples=samples,
                                  cache_dir=cache_dir, user_pairs=user_pairs)[inverse.reshape(-1)]

    return free


def free_solutions(sol: AllSolutions, free: Filter) -> tuple[AllSolutions, np.ndarray]:
    """``(the solutions of sol that free accepts, dropped (N,))``: the padded arrays of
    :class:`~kinematics.algorithms.ik_all.AllSolutions` compacted per target, order kept; ``dropped``
    the number of solutions of each target left out as colliding."""
    N, K = sol.q.shape[:2]
    listed = np.arange(K)[None, :] < sol.count[:, None]  # (N, K)
    n_idx, k_idx = np.nonzero(listed)
    keep = np.zeros((N, K), bool)
    if n_idx.size:
        keep[n_idx, k_idx] = np.asarray(free(sol.q[n_idx, k_idx]), dtype=bool)
    count = keep.sum(axis=1).astype(np.int64)
    dropped = sol.count - count
    K2 = int(count.max(initial=0))
    # a stable order: kept solutions first, each target's own order unchanged
    order = np.argsort(~keep, axis=1, kind="stable")[:, :K2]
    rows = np.arange(N)[:, None]
    inside = np.arange(K2)[None, :] < count[:, None]

    def take(a: np.ndarray, pad) -> np.ndarray:
        out = a[rows, order] if K2 else a[:, :0]
        mask = inside.reshape(inside.shape + (1,) * (out.ndim - 2))
        return np.where(mask, out, pad)

    return dataclasses.replace(sol, q=take(sol.q, np.nan), count=count, within_limits=take(sol.within_limits, False),
                               singular=take(sol.singular, False), position_error=take(sol.position_error, np.nan),
                               rotation_error=take(sol.rotation_error, np.nan)), dropped
