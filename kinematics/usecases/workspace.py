"""The sampled workspace of the query's link (or of its point / tool frame)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..algorithms import workspace as _workspace
from ..algorithms.collision_matrix import DEFAULT_SAMPLES as COLLISION_SAMPLES
from ..algorithms.ik import middle_of_limits
from ..engine.poe import require_one_dof
from ..errors import KinematicsError
from ..model.robot import RobotModel
from .collision import collision_filter
from .query import Query


def workspace(query: Query | RobotModel, link: str | None = None, *, samples: int = _workspace.DEFAULT_SAMPLES,
              voxel: float | None = None, measure: str = "pose", random_seed: int = 0, progress=None,
              collision_free: bool = False, collision_samples: int = COLLISION_SAMPLES, cache_dir: Any = None,
              **options: Any) -> _workspace.Workspace:
    """The sampled workspace of the query's ``link`` (None: the first leaf link; ``link`` here
    overrides it, ``workspace(model, "tool0")``), or of the frame ``point`` / ``tool`` on it:
    ``samples`` configurations drawn uniformly within the limits (seeded by ``random_seed``),
    their positions and manipulability (``measure``: ``pose``, the 6 x k Jacobian, or
    ``position``, its 3 rows), the bounding box, reach, an occupancy-grid volume (area for a
    planar arm) with its convergence and the dexterity map on cells of edge ``voxel`` (None:
    chosen from the samples); see :mod:`kinematics.algorithms.workspace`. ``samples`` is bounded
    by the budget's ``max_workspace_samples``; ``progress(n)`` is called after each chunk of n
    samples.

    ``collision_free``: only the samples free of self-collision are kept (the enabled pairs of the
    model's allowed-collision matrix from ``collision_samples`` configurations, kept in
    ``cache_dir``; a model without collision geometry is a
    :class:`~kinematics.errors.CollisionError`); the joints off the link's path, which the samples
    leave alone, are checked at the middle of their limits (a gripper half open); the answer's
    ``samples`` are those kept and ``dropped`` counts the others."""
    if link is not None:
        options["link"] = link
    query = Query.of(query, **options)
    model = query.robot
    link = model.leaf_links[0] if query.link is None else query.link
    compiled = require_one_dof(model, "the workspace")
    index = int(compiled.link_indices([link])[0])
    samples = int(samples)
    if samples < 1:
        raise KinematicsError(f"samples: {samples}; give at least 1")
    query.budget.check_workspace_samples(samples)
    keep = None
    if collision_free:
        free = collision_filter(model, "collision_free", samples=collision_samples, cache_dir=cache_dir,
                                user_pairs=query.collision_pairs)
        path = compiled.kernel.path_columns(index)
        off = np.setdiff1d(np.arange(model.dof), path)
        middle = middle_of_limits(model)

        def keep(Q: np.ndarray) -> np.ndarray:
            if off.size:
                Q = Q.copy()
                Q[:, off] = middle[off]
            return free(Q)

    return _workspace.workspace(model, link, samples, tool=query.T_tool, measure=measure, voxel=voxel,
                                random_seed=random_seed, progress=progress, keep=keep)
