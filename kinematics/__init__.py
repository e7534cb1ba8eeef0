"""Kinematics library: robot models from URDF and DH tables, product-of-exponentials FK and
Jacobians in compiled kernels, cross-checked against Pinocchio. No web code.

The package is layered, each layer importing only those below it (an import contract in
``pyproject.toml`` checks it): :mod:`~kinematics.spatial` (SO(3)/SE(3)) <
:mod:`~kinematics.model` (the immutable robot model, q) < :mod:`~kinematics.io` (URDF, DH
tables, catalogue, files) and :mod:`~kinematics.engine` (compiled PoE kernels) <
:mod:`~kinematics.algorithms` (FK, Jacobians, DH forms, ...) < :mod:`~kinematics.verify`
(Pinocchio) < :mod:`~kinematics.usecases` (the use cases, each taking a :class:`Query`) <
:mod:`~kinematics.api` (their historical address) < :mod:`~kinematics.cli`.

Typical use::

    >>> import kinematics
    >>> ur5 = kinematics.default_catalogue().get("ur5")
    >>> kinematics.fk(ur5, [0.0] * 6, links=["tool0"]).poses.shape
    (1, 1, 4, 4)
    >>> kinematics.jacobian(ur5, [[0.0] * 6] * 3, link="tool0", reference="local").jacobians.shape
    (3, 6, 6)
    >>> query = kinematics.Query(ur5, link="tool0", point=[0.0, 0.0, 0.1])
    >>> kinematics.ik(query, kinematics.fk(query.replace(links=["tool0"]), [0.3] * 6).poses[0, 0]).solution.success
    array([ True])
"""

from .usecases import (Budget, CollisionAnswer, CollisionAvoidance, IKOptions, IKSettings, SolutionSet, FKAnswer, IKAllAnswer, IKAnswer, JacobianAnswer, Query, TaskAnswer,
                       Verification, VelocityAnswer, calibrate, calibration_poses, collision, collision_free,
                       collision_matrix, fk, ik, ik_all, ik_family, ik_path, jacobian, joint_batch, load_model,
                       symbolic, symbolic_dh, task, velocity, warm_up, workspace)
from .usecases import UserPairs
from .usecases.trajectory import ToolSpeed, TrajectoryLimits, trajectory
from .engine.parallel import set_threads, thread_count, threads
from .engine.poe import PoEModel, compile_model
from .engine.single import fk_function, jacobian_function
from .errors import (
    BasePoseError,
    BudgetError,
    DHError,
    JointValueError,
    KinematicsError,
    LimitError,
    NoDHFormError,
    ReferenceUnavailableError,
    UnknownLinkError,
    UnknownModelError,
    UnsupportedJointError,
    URDFError,
)
from .io.catalogue import Catalogue, default_catalogue
from .io.urdf import load_urdf, parse_urdf
from .model.joint_values import as_batch, out_of_limits, require_within_limits
from .model.robot import Joint, Limits, Mimic, RobotModel
from .spatial.reference import REFERENCES, Reference

__version__ = "0.1.0"

__all__ = [
    "Budget", "FKAnswer", "IKAnswer", "JacobianAnswer", "Query", "TaskAnswer", "Verification", "VelocityAnswer", "fk",
    "ik", "jacobian", "joint_batch", "load_model", "symbolic", "symbolic_dh", "task", "velocity", "warm_up",
    "workspace", "CollisionAnswer", "IKAllAnswer", "calibrate", "calibration_poses", "collision", "collision_free",
    "collision_matrix", "ik_all", "ik_family", "ik_path", "CollisionAvoidance", "IKOptions", "IKSettings", "SolutionSet",
    "UserPairs", "ToolSpeed", "TrajectoryLimits", "trajectory",
    "PoEModel", "compile_model", "set_threads", "thread_count", "threads", "fk_function",
    "jacobian_function", "BasePoseError", "BudgetError", "DHError", "JointValueError", "KinematicsError",
    "LimitError", "NoDHFormError", "ReferenceUnavailableError", "UnknownLinkError", "UnknownModelError",
    "UnsupportedJointError", "URDFError", "Catalogue", "default_catalogue", "load_urdf", "parse_urdf", "as_batch",
    "out_of_limits", "require_within_limits", "Joint", "Limits", "Mimic", "RobotModel", "REFERENCES", "Reference",
    "__version__",
]
