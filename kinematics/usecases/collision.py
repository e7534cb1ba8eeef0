"""Self-collision of configurations, and the allowed-collision matrix they are checked with.

Geometry is the URDF's ``<collision>`` elements (:mod:`kinematics.io.collision_geometry`: primitives
always; meshes only from the installed catalogue packages or an uploaded archive); the checked
pairs are those the model's allowed-collision matrix leaves enabled
(:mod:`kinematics.algorithms.collision_matrix`); coal answers each pair
(:mod:`kinematics.algorithms.collision`).

>>> from kinematics.io import default_catalogue
>>> ur5 = default_catalogue().get("ur5")
>>> folded = [0, -1.0, 2.9, 0, 0, 0]  # the elbow shut: the wrist inside the upper arm
>>> answer = collision(ur5, [[0, -1.57, 0, -1.57, 0, 0], folded], samples=300)
>>> answer.colliding.tolist(), answer.pairs[1][:2]
([False, True], [('shoulder_link', 'wrist_2_link'), ('upper_arm_link', 'wrist_1_link')])
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from ..algorithms import self_collision as _sc
from ..algorithms.collision_matrix import DEFAULT_SAMPLES, CollisionMatrix, UserPairs
from ..errors import CollisionError
from ..model.robot import RobotModel
from .query import Query

#: the most configurations one matrix may sample
MAX_MATRIX_SAMPLES = 1_000_000


@dataclass(frozen=True)
class CollisionAnswer:
    """Self-collision of one configuration or a batch of N.

    ``colliding`` (N,) bool; ``pairs`` per configuration the link pairs in collision (each in
    ``links`` order); with distances ``min_distance`` (N,) the minimum over the checked pairs (m;
    negative: penetration, where coal measures it; inf when no pair is checked), ``closest`` per
    configuration the pair achieving it (or None) and ``points`` (N, 2, 3) its witness points in
    the root frame; ``checked`` the pairs looked at, ``links`` those with collision geometry,
    ``warnings`` what the geometry left out."""

    joint_names: tuple[str, ...]
    is_batch: bool
    colliding: np.ndarray
    pairs: list
    checked: list
    links: tuple[str, ...]
    warnings: tuple[str, ...]
    min_distance: np.ndarray | None = None
    closest: list | None = None
    points: np.ndarray | None = None


def _samples(samples: int) -> int:
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or not 1 <= samples <= MAX_MATRIX_SAMPLES:
        raise CollisionError(f"samples: {samples!r}; give an integer in [1, {MAX_MATRIX_SAMPLES}]")
    return int(samples)


def collision(query: Query | RobotModel, q: Any, *, distance: bool = False, margin: float = 0.0,
              samples: int = DEFAULT_SAMPLES, cache_dir: os.PathLike | str | None = None,
              **options: Any) -> CollisionAnswer:
    """Self-collision of ``q`` (one configuration or a batch, any form the query reads) on the
    enabled pairs of the model's allowed-collision matrix (``samples`` configurations; kept in
    ``cache_dir``). ``margin`` (m, >= 0): closer than that counts as colliding. ``distance``:
    also the minimum distance, the closest pair and its witness points. The query's
    ``collision_pairs`` (:class:`UserPairs`) allow and forbid pairs."""
    query = Query.of(query, **options)
    if isinstance(margin, bool) or not isinstance(margin, (int, float)) or not np.isfinite(margin) or margin < 0:
        raise CollisionError(f"margin: {margin!r}; give a finite distance >= 0 m")
    Q, is_batch = query.joints(q)
    model = query.robot
    cm = _sc.geometry(model)
    checked = _sc.matrix(model, _samples(samples), cache_dir=cache_dir, user_pairs=query.collision_pairs).enabled()
    r = cm.check(Q, checked, margin=float(margin), distance=bool(distance))
    return CollisionAnswer(model.q_labels, is_batch, r.colliding, r.pairs, checked, cm.links,
                           cm.warnings + _unchecked(cm.links, checked), r.min_distance, r.closest, r.points)


def _unchecked(links: tuple[str, ...], checked: list) -> tuple[str, ...]:
    """A warning when no pair is checked: ``colliding: false`` then means "not checked", not "free"."""
    if not links:
        return ("the model has no collision geometry (no <collision> elements, or none that could be read): "
                "no pair was checked, so colliding false says nothing",)
    if not checked:
        return (f"no pair was checked: every pair of the {len(links)} links with collision geometry is disabled in "
                "the allowed-collision matrix (GET .../collision/matrix), so colliding false says nothing",)
    return ()


def collision_matrix(query: Query | RobotModel, samples: int = DEFAULT_SAMPLES, *,
                     cache_dir: os.PathLike | str | None = None, user: Sequence[Sequence[str]] = (),
                     progress: Callable[[int], None] | None = None, **options: Any) -> CollisionMatrix:
    """The model's allowed-collision matrix: ``adjacent``, ``always`` and ``never`` pairs over
    ``samples`` random configurations (computed once, kept in ``cache_dir``), and ``user`` pairs
    disabled; the query's ``collision_pairs`` (:class:`UserPairs`) allowed and forbidden;
    ``progress(k)`` is told the configurations sampled so far."""
    query = Query.of(query, **options)
    return _sc.matrix(query.robot, _samples(samples), cache_dir=cache_dir, user=user,
                      user_pairs=query.collision_pairs, progress=progress)


def collision_free(query: Query | RobotModel, Q: Any, *, margin: float = 0.0, samples: int = DEFAULT_SAMPLES,
                   cache_dir: os.PathLike | str | None = None, **options: Any) -> np.ndarray:
    """(N,) bool: which configurations of ``Q`` are free of self-collision (the matrix's enabled
    pairs with the query's ``collision_pairs``; closer than ``margin`` counts as colliding)."""
    query = Query.of(query, **options)
    Q, _ = query.joints(Q)
    return _sc.collision_free(query.robot, Q, margin=margin, samples=_samples(samples), cache_dir=cache_dir,
                              user_pairs=query.collision_pairs)


def collision_filter(model: RobotModel, field: str, *, samples: int = DEFAULT_SAMPLES, margin: float = 0.0,
                     cache_dir: os.PathLike | str | None = None,
                     user_pairs: UserPairs | None = None) -> Callable[[np.ndarray], np.ndarray]:
    """The filter of collision-free IK, paths and workspaces: ``free(Q)`` (R, dof) -> (R,) bool on the
    matrix's enabled pairs with ``user_pairs`` (a query's ``collision_pairs``)
    (:func:`kinematics.algorithms.ik_collision.self_collision_filter`).

    A model without collision geometry on any link cannot tell a colliding configuration from a
    free one, so asking ``field`` of it is a :class:`~kinematics.errors.CollisionError` naming the
    model and what its geometry left out (never a silent "free"). A model with floating or planar
    joints is refused too (self-collision is checked on one-dof joints)."""
    from ..algorithms.ik_collision import self_collision_filter

    if model.multi_dof:
        raise CollisionError(f"{field}: self-collision is checked on models with one-dof joints only "
                             f"(model {model.name!r} has floating or planar joints; without floating_base, give the base pose "
                             "as base)")
    cm = _sc.geometry(model)
    if not cm.links:
        left_out = f" ({'; '.join(cm.warnings)})" if cm.warnings else ""
        raise CollisionError(f"{field}: model {model.name!r} has no collision geometry{left_out}, so no "
                             "configuration can be told free of self-collision; give a URDF with <collision> "
                             "elements (meshes inside an uploaded archive), or leave the option out")
    return self_collision_filter(model, samples=_samples(samples), margin=margin, cache_dir=cache_dir,
                                 user_pairs=user_pairs)
