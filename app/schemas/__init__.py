"""Wire schemas (pydantic): requests, responses and their OpenAPI examples, one module an operation.

:mod:`app.schemas.common` holds the JSON types, poses, the problem and :class:`QueryRequest`, the
base of every request on a model's frames (it declares the fields of :class:`kinematics.Query`
once and builds the query); :mod:`~app.schemas.models`, :mod:`~app.schemas.fk`,
:mod:`~app.schemas.jacobian`, :mod:`~app.schemas.ik`, :mod:`~app.schemas.ik_all`, :mod:`~app.schemas.velocity`,
:mod:`~app.schemas.workspace`, :mod:`~app.schemas.symbolic` and :mod:`~app.schemas.calibration` the operations'. Every name is
importable from ``app.schemas`` itself.
"""

from pydantic import BaseModel

from .calibration import *  # noqa: F403
from .collision import *  # noqa: F403
from .common import *  # noqa: F403
from .common import (_BASE_DESC, _FLOATING_BASE_DESC, _LIMITS_DESC, _NORMALIZE_DESC, _POINT_DESC,  # noqa: F401
                     _Q_DESC, _REPRESENTATION_DESC, _TOOL_DESC)
from .fk import *  # noqa: F403
from .ik import *  # noqa: F403
from .ik import _POSE_DESC  # noqa: F401
from .ik_all import *  # noqa: F403
from .jacobian import *  # noqa: F403
from .models import *  # noqa: F403
from .symbolic import *  # noqa: F403
from .trajectory import *  # noqa: F403
from .velocity import *  # noqa: F403
from .workspace import *  # noqa: F403
from .fk import FKRequest
from .ik import IKRequest
from .ik_all import IKPathRequest
from .jacobian import JacobianRequest
from .models import AxesDescriptionIn, DHTable, PoEDescriptionIn, URDFUpload
from .common import Problem
from .velocity import VelocityRequest
from .workspace import WorkspaceRequest
from .calibration import CalibrationPosesRequest, CalibrationRequest
from .collision import CollisionRequest
from .trajectory import TrajectoryRequest

#: the request schemas whose JSON Schema the OpenAPI document lists (bodies some handlers read themselves)
REQUEST_SCHEMAS: tuple[type[BaseModel], ...] = (FKRequest, JacobianRequest, IKRequest, IKPathRequest, VelocityRequest,
                                                WorkspaceRequest, URDFUpload, DHTable, PoEDescriptionIn,
                                                AxesDescriptionIn, CalibrationRequest, CalibrationPosesRequest,
                                                CollisionRequest, TrajectoryRequest, Problem)
