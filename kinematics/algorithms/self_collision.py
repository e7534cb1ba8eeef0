"""Self-collision of a model, end to end: its geometry, its allowed-collision matrix, the check.

The functions the use cases, the CLI and other algorithms (collision-free IK, workspace
filtering) call; the geometry comes from where the model's meshes are vouched for
(:func:`kinematics.io.collision_geometry.mesh_source`: the installed catalogue packages, or an
uploaded archive), and every check looks at the matrix's enabled pairs.

>>> import numpy as np
>>> from kinematics.io import default_catalogue
>>> panda = default_catalogue().get("panda")
>>> ready = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785, 0.02]
>>> zero = np.zeros(panda.nq)  # the arm stretched out (joint 4 past its limit), the fingers shut
>>> collision_free(panda, [ready, zero], samples=200).tolist()
[True, False]
>>> check(panda, [zero], samples=200).pairs[0]
[('panda_link5', 'panda_link7'), ('panda_link5', 'panda_hand'), ('panda_leftfinger', 'panda_rightfinger')]
"""

from __future__ import annotations

import os
import threading
import weakref
from typing import Callable, Sequence

import numpy as np

from ..io.collision_geometry import CollisionGeometry, collision_geometry
from ..model.robot import RobotModel
from .collision import CollisionModel, CollisionResult, collision_model
from .collision_matrix import DEFAULT_SAMPLES, CollisionMatrix, UserPairs
from .collision_matrix import collision_matrix as _matrix

_geometries: "weakref.WeakKeyDictionary[RobotModel, CollisionGeometry]" = weakref.WeakKeyDictionary()
_matrices: "weakref.WeakKeyDictionary[CollisionModel, dict]" = weakref.WeakKeyDictionary()
_lock = threading.Lock()


def geometry(model: RobotModel) -> CollisionModel:
    """The model's :class:`~kinematics.algorithms.collision.CollisionModel` (built once per model)."""
    with _lock:
        g = _geometries.get(model)
    if g is None:
        g = collision_geometry(model)
        with _lock:
            g = _geometries.setdefault(model, g)
    return collision_model(model, g)


def matrix(model: RobotModel, samples: int = DEFAULT_SAMPLES, *, cache_dir: os.PathLike | str | None = None,
           user: Sequence[Sequence[str]] = (), user_pairs: UserPairs | None = None,
           progress: Callable[[int], None] | None = None) -> CollisionMatrix:
    """The model's allowed-collision matrix from ``samples`` configurations (kept per model in
    memory and, with ``cache_dir``, on disk), with ``user`` pairs also disabled and ``user_pairs``
    (:class:`~kinematics.algorithms.collision_matrix.UserPairs`) allowed and forbidden."""
    cm = geometry(model)
    key = (samples, None if cache_dir is None else str(cache_dir))  # a new cache directory gets its file
    with _lock:
        per = _matrices.setdefault(cm, {})
        found = per.get(key)
    if found is None:
        found = _matrix(cm, samples, cache_dir=cache_dir, progress=progress)
        with _lock:
            per[key] = found
    elif progress is not None:
        progress(samples)
    if user:
        user_pairs = UserPairs(allow=user).then(user_pairs)
    return found.with_pairs(user_pairs, model.links)


def check(model: RobotModel, Q, *, distance: bool = False, margin: float = 0.0,
          pairs: Sequence[tuple[str, str]] | None = None, samples: int = DEFAULT_SAMPLES,
          cache_dir: os.PathLike | str | None = None, stop_at_first: bool = False,
          user_pairs: UserPairs | None = None, progress: Callable[[int], None] | None = None) -> CollisionResult:
    """Self-collision of every configuration of ``Q`` (N, nq) on ``pairs`` (default: the
    matrix's enabled pairs, with ``user_pairs``); see :meth:`CollisionModel.check`."""
    cm = geometry(model)
    if pairs is None:
        pairs = matrix(model, samples, cache_dir=cache_dir, user_pairs=user_pairs).enabled()
    return cm.check(Q, pairs, margin=margin, distance=distance, stop_at_first=stop_at_first, progress=progress)


def collision_free(model: RobotModel, Q, *, margin: float = 0.0, samples: int = DEFAULT_SAMPLES,
                   cache_dir: os.PathLike | str | None = None, user_pairs: UserPairs | None = None) -> np.ndarray:
    """(N,) bool: which configurations of ``Q`` (N, nq) are free of self-collision on the matrix's
    enabled pairs, with ``user_pairs`` (closer than ``margin`` counts as colliding). A model
    without collision geometry is free everywhere."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    return ~check(model, Q, margin=margin, samples=samples, cache_dir=cache_dir, stop_at_first=True,
                  user_pairs=user_pairs).colliding
