"""Kinematics library: URDF and DH robot models, product-of-exponentials FK and Jacobians.

Python, numpy and numba-compiled kernels; no web code. Typical use::

    from kinematics import default_catalogue, compile_model, as_batch
    model = default_catalogue().get("ur5")
    Q, _ = as_batch(model, [0.0] * model.dof)
    T = compile_model(model).fk(Q, ["tool0"])          # (1, 1, 4, 4)
    J = compile_model(model).jacobian(Q, "tool0", "local_world_aligned")  # (1, 6, 6)
"""

from .catalogue import Catalogue, default_catalogue
from .errors import (
    BasePoseError,
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
from .joints import as_batch, out_of_limits, require_within_limits
from .measures import conditioning, pose_components
from .model import Joint, Limits, Mimic, RobotModel
from .poe import REFERENCES, PoEModel, compile_model, warm_up
from .urdf import load_urdf, parse_urdf

__version__ = "0.1.0"

__all__ = [
    "Catalogue", "default_catalogue", "BasePoseError", "DHError", "JointValueError", "KinematicsError", "LimitError",
    "NoDHFormError", "ReferenceUnavailableError", "UnknownLinkError", "UnknownModelError",
    "UnsupportedJointError", "URDFError", "as_batch", "out_of_limits", "require_within_limits",
    "conditioning", "pose_components", "Joint", "Limits", "Mimic", "RobotModel", "REFERENCES",
    "PoEModel", "compile_model", "load_urdf", "parse_urdf", "warm_up", "__version__",
]
