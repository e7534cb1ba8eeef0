"""The use cases under their historical address: ``kinematics.api.fk`` is :func:`kinematics.usecases.fk`.

The use cases live in :mod:`kinematics.usecases`, one module a concept, and are exported from
:mod:`kinematics` itself (``kinematics.fk``, ``kinematics.ik``, ``kinematics.Query``, ...); this
module re-exports every name it has always had, so existing callers keep working.

>>> from kinematics.io import default_catalogue
>>> answer = fk(default_catalogue().get("ur5"), [0.0] * 6, links=["tool0"])
>>> answer.poses.shape, answer.is_batch, answer.out_of_limits()
((1, 1, 4, 4), False, [[]])
"""

from __future__ import annotations

from .usecases import (DEFAULT_SYMBOLIC_TIMEOUT, DESCRIPTION_KINDS, LIMIT_POLICIES, SYMBOLIC_FORMATS, SYMBOLIC_WHAT,
                       UNBOUNDED, Budget, Cancellation, FKAnswer, IKAllAnswer, IKAnswer, JacobianAnswer, Query,
                       SymbolicAnswer, TaskAnswer, Verification, VelocityAnswer, cancellable, compiled_models,
                       description_urdf, dh_form, fk, ik, ik_all, ik_family, ik_path, jacobian, joint_batch,
                       load_model, model_for, model_from_description, reference_name, resolve_links, screws,
                       symbolic, symbolic_dh, task, velocity, warm_up, workspace)
from .usecases import CollisionAnswer, UserPairs, collision, collision_free, collision_matrix  # noqa: F401
from .io.collision_geometry import with_geometry_warnings  # noqa: F401 - the registry adds mesh warnings with it
from .usecases.query import Answer as _Answer, prefixed as _prefixed  # noqa: F401 - former private names

__all__ = [
    "DEFAULT_SYMBOLIC_TIMEOUT", "DESCRIPTION_KINDS", "LIMIT_POLICIES", "SYMBOLIC_FORMATS", "SYMBOLIC_WHAT",
    "UNBOUNDED", "Budget", "Cancellation", "FKAnswer", "IKAllAnswer", "IKAnswer", "JacobianAnswer", "Query",
    "SymbolicAnswer", "TaskAnswer", "Verification", "VelocityAnswer", "cancellable", "compiled_models",
    "description_urdf", "dh_form", "fk", "ik", "ik_all", "ik_family", "ik_path", "jacobian", "joint_batch",
    "load_model", "model_for", "model_from_description", "reference_name", "resolve_links", "screws", "symbolic",
    "symbolic_dh", "task", "velocity", "warm_up", "workspace",
    "CollisionAnswer", "collision", "collision_free", "collision_matrix", "with_geometry_warnings", "UserPairs",
]
