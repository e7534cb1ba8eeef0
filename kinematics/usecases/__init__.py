"""The use cases: what the service's routes and the command line ask of the library, one module a concept.

Each takes a :class:`~kinematics.usecases.query.Query` ("which frame of which model, how": link(s),
point / tool, base, floating base, normalisation, limits policy, verification, budget) and its own
arguments: :func:`fk` ``(query, q)``, :func:`jacobian` ``(query, q, reference=...)``,
:func:`velocity` ``(query, q, qdot)``, :func:`ik` ``(query, target, ...)`` (every solution: ``solutions="all"``,
:func:`ik_all`; :func:`ik_family`, :func:`ik_path`), :func:`workspace`
``(query, samples=...)``, :func:`task` ``(query, q, representation=...)``, :func:`calibrate`
``(query, measurements, ...)`` and :func:`calibration_poses` ``(query, n, ...)``, :func:`trajectory` ``(query, waypoints, limits, ...)``; closed forms
(:func:`symbolic`, :func:`symbolic_dh`) and models (:func:`load_model`, :func:`model_from_description`,
...) take what they need. The answers are plain objects of numpy arrays; turning them into JSON or
``.npy`` is the caller's business.

Long calls stop early inside a ``with cancellable(Cancellation(timeout=..., setting=...)):`` block
when the token is cancelled (:class:`~kinematics.errors.CancelledError`) or its time budget runs
out (:class:`~kinematics.errors.TimeBudgetError`); see :mod:`kinematics.engine.cancel`.

>>> from kinematics.io import default_catalogue
>>> query = Query(default_catalogue().get("ur5"), links=["tool0"], verify=True)
>>> answer = fk(query, [0.0] * 6)
>>> answer.poses.shape, answer.verification.max_position_error < 1e-9
((1, 1, 4, 4), True)
"""

from ..engine.cancel import Cancellation, cancellable
from ..engine.cancel import check as check_cancelled
from .calibration import calibrate, calibration_measurements, calibration_poses
from .collision import CollisionAnswer, UserPairs, collision, collision_free, collision_matrix
from .fk import FKAnswer, fk
from .ik import IKAnswer, ik
from .ik_all import IKAllAnswer, ik_all, ik_family, ik_path
from .ik_options import CollisionAvoidance, IKOptions, IKSettings, SolutionSet
from .ik_redundant import IKRedundantAnswer, ik_redundant
from .jacobian import JacobianAnswer, jacobian
from .models import (DESCRIPTION_KINDS, compiled_models, description_urdf, dh_form, load_model,
                     model_from_description, reference_name, screws)
from .query import (LIMIT_POLICIES, UNBOUNDED, Answer, Budget, Query, Verification, joint_batch, model_for,
                    resolve_links)
from .symbolic import (DEFAULT_SYMBOLIC_TIMEOUT, SYMBOLIC_FORMATS, SYMBOLIC_WHAT, SymbolicAnswer, symbolic,
                       symbolic_dh)
from .task import TaskAnswer, task
from .trajectory import Sampling, ToolSpeed, TrajectoryAnswer, TrajectoryError, TrajectoryLimits, trajectory
from .velocity import VelocityAnswer, velocity
from .visual import visual_geometry, visual_mesh
from .warm import warm_up
from .workspace import workspace

__all__ = [
    "Cancellation", "cancellable", "check_cancelled", "calibrate", "calibration_measurements", "calibration_poses", "FKAnswer", "fk",
    "IKAnswer", "ik", "IKAllAnswer", "ik_all", "ik_family", "ik_path", "IKRedundantAnswer", "ik_redundant", "CollisionAvoidance", "IKOptions", "IKSettings",
    "SolutionSet", "JacobianAnswer", "jacobian",
    "DESCRIPTION_KINDS", "compiled_models", "description_urdf", "dh_form", "load_model", "model_from_description",
    "reference_name", "screws", "warm_up", "LIMIT_POLICIES", "UNBOUNDED", "Answer", "Budget", "Query",
    "Verification", "joint_batch", "model_for", "resolve_links", "DEFAULT_SYMBOLIC_TIMEOUT", "SYMBOLIC_FORMATS",
    "SYMBOLIC_WHAT", "SymbolicAnswer", "symbolic", "symbolic_dh", "TaskAnswer", "task", "VelocityAnswer", "velocity",
    "workspace", "CollisionAnswer", "collision", "collision_free", "collision_matrix", "UserPairs",
    "visual_geometry", "visual_mesh", "Sampling", "ToolSpeed", "TrajectoryAnswer", "TrajectoryError",
    "TrajectoryLimits", "trajectory",
]
