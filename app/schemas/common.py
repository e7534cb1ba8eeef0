"""Wire schemas shared by every operation: JSON types, poses, the problem, and :class:`QueryRequest`.

Field names follow the API contract (``docs/design.md``). Matrices are row-major
nested lists; quaternions are objects ``{w, x, y, z}``; Jacobians are 6 x dof with the
linear rows first. JSON has no infinity: a condition number at a singularity is ``null``.

:class:`QueryRequest` declares, once, the request fields of :class:`kinematics.Query` ("which
frame of which model, how": base, point, tool, verify, floating_base, normalize; with
:class:`JointsRequest`, ``q`` and ``limits``) and builds the query with :meth:`QueryRequest.to_query`.
An operation's request schema derives from it and adds its own fields.
"""

from __future__ import annotations

from typing import Annotated, Any, Callable, ClassVar, Iterable, Iterator, Literal, Union

from pydantic import AllowInfNan, BaseModel, BeforeValidator, ConfigDict, Field, Strict

from kinematics.spatial.reference import Reference
from kinematics.usecases import UNBOUNDED, Budget, Query, check_cancelled

Number = Annotated[float, Strict()]  # a JSON number (not a string, not a boolean)
#: a number a client chooses as a size, a time or a tolerance: finite (NaN and Infinity are refused as such,
#: not as out of a range they are not comparable with)
Finite = Annotated[float, Strict(), AllowInfNan(False)]
Flag = Annotated[bool, Strict()]  # true or false (not 0, 1 or "yes")


def _json_integer(value: Any) -> Any:
    if isinstance(value, (bool, str)):
        raise ValueError(f"expected an integer, got {'a boolean' if isinstance(value, bool) else 'a string'}")
    return value


Integer = Annotated[int, BeforeValidator(_json_integer)]  # a JSON integer (2.0 too; not "2", not true)
Vector = list[Number]
Matrix = list[list[Number]]
JointVector = list[Number]
#: a joint's value in a name map: a number; a floating joint 7 numbers (x, y, z, qx, qy, qz, qw) or a pose
#: object ({"position", "quaternion"}, {"xyz", "rpy"}, a 4x4 matrix); a planar joint 4 (x, y, cos, sin)
JointMapValue = Union[Number, list[Number], list[list[Number]], dict[str, Any]]
JointMap = dict[str, JointMapValue]
#: q as the contract allows it: a vector in joint_names order, a name map, or a list of those (a batch)
JointValues = Union[JointVector, JointMap, list[JointVector], list[JointMap]]

References = Reference  # the reference frames: one enum, the library's
LimitPolicy = Literal["report", "refuse"]
PoseFormat = Literal["pose", "matrix", "compact"]

UR5_HOME = [0.0, -1.5707963267948966, 1.5707963267948966, 0.0, 1.5707963267948966, 0.0]


class Quaternion(BaseModel):
    w: Number
    x: Number
    y: Number
    z: Number


_Q_DESC = ("joint values: a vector in the order of joint_names, a {joint_name: value} map, "
           "or a list of those (a batch)")
_LIMITS_DESC = "report: compute and list out-of-limit joints in out_of_limits; refuse: answer 422 naming the joint"


class BaseXyzRpy(BaseModel):
    """T_world_root as a translation and URDF roll-pitch-yaw."""

    model_config = ConfigDict(extra="forbid")
    xyz: Vector = Field(description="metres")
    rpy: Vector = Field(description="radians, R = Rz(yaw) Ry(pitch) Rx(roll)")


class BasePositionQuaternion(BaseModel):
    """T_world_root as a position and a unit quaternion."""

    model_config = ConfigDict(extra="forbid")
    position: Vector = Field(description="metres")
    quaternion: Quaternion


BasePose = Union[BaseXyzRpy, BasePositionQuaternion, Matrix]
_BASE_DESC = ("the root link's pose in the world, T_world_root (default: the world is the root link's frame): "
              '{"xyz", "rpy"}, {"position", "quaternion"} or a 4x4 matrix; for a batch, one pose or a list with '
              "one pose per configuration. verify compares the root-frame results with Pinocchio. Velocities: the base is "
              "at rest.")


Point = Annotated[list[Number], Field(min_length=3, max_length=3)]
_POINT_DESC = ("a point [x, y, z] in the link frame, metres: the answer is then that of a frame there with the "
               "link's axes (a tool centre point without editing the URDF); not with tool")
_TOOL_DESC = ("T_link_tool, a tool frame fixed to the link: {\"xyz\", \"rpy\"}, {\"position\", \"quaternion\"} or a 4x4 "
              "matrix. Poses become T_world_link @ T_link_tool; Jacobians and velocities are those of that frame "
              "(Pinocchio's frame semantics: local_world_aligned and world rows take its origin as reference point, "
              "local also turns into its axes); IK targets are its poses. Not with point")


_FLOATING_BASE_DESC = ("compute with the model on a free-flyer root joint 'root_joint' above its root link (as "
                       "Pinocchio's buildModelFromUrdf(path, JointModelFreeFlyer())): q starts with x, y, z, qx, qy, "
                       "qz, qw of the root link in the world, velocities and Jacobian columns with its twist (6, "
                       "linear first, in the root link's frame)")
_NORMALIZE_DESC = ("scale floating joints' quaternions and planar joints' (cos, sin) to unit norm instead of "
                   "refusing them (422) when their norm is off 1 by more than 1e-6")


TaskRepresentationName = Literal["rpy", "zyx", "zyz", "quaternion", "rotvec", "position", "scara", "planar"]
_REPRESENTATION_DESC = ("task vector r = (p, phi): rpy | zyx | zyz | quaternion | rotvec, or a named subset: "
                        "position (px, py, pz), scara (px, py, pz, alpha_z), planar (px, py, phi)")

class Problem(BaseModel):
    """An error (``application/problem+json``)."""

    model_config = ConfigDict(extra="allow")
    type: str
    title: str
    status: int
    detail: str
    field: str | None = None



#: the fields of :class:`kinematics.Query` a request schema may carry (each is optional on a schema)
QUERY_FIELDS = ("link", "links", "point", "tool", "base", "floating_base", "normalize", "limits", "verify")


def checked(items: Iterable, every: int = 1024) -> Iterator:
    """``items``, with the request's cancellation checked every ``every`` of them: for the loops that
    build a large answer (its budget and its client hold there too; outside heavy work, no check)."""
    for i, item in enumerate(items):
        if i % every == 0:
            check_cancelled()
        yield item


def one_or_all(is_batch: bool) -> Callable[[Any], Any]:
    """Batch unwrapping: the per-configuration values as they are for a batch, else the first one."""
    return (lambda values: values) if is_batch else (lambda values: values[0])


def _plain(value: Any) -> Any:
    """A request value as the library reads it: pydantic models (a pose object) as dicts."""
    if isinstance(value, BaseModel):
        return value.model_dump()
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return value


class ToQuery:
    """``to_query``: the :class:`kinematics.Query` of a request schema (of :attr:`query_fields`, those it has)."""

    #: the request fields that are the query's (a schema whose field of that name means something else leaves it out)
    query_fields: ClassVar[tuple[str, ...]] = QUERY_FIELDS

    def to_query(self, model, budget: Budget = UNBOUNDED, **options: Any) -> Query:
        """The :class:`kinematics.Query` of this request on ``model`` within ``budget`` (``options``
        override fields, e.g. the link a route chose)."""
        fields = type(self).model_fields
        values = {name: _plain(getattr(self, name)) for name in self.query_fields if name in fields}
        return Query(model, budget=budget, **{**values, **options})


class QueryRequest(ToQuery, BaseModel):
    """The options every request on a model's frames shares, declared once (``kinematics.Query``).

    ``to_query(model, budget)`` builds the :class:`kinematics.Query` of a request: these fields,
    and the subclass's ``link`` / ``links`` / ``limits`` when it has them. A request read by
    ``app.adapter.read_request`` (JSON or ``.npy``) is an instance of its schema too."""

    model_config = ConfigDict(extra="forbid")
    verify: Flag = Field(default=False, description="also check the answer with Pinocchio and report the deviations "
                                                    "(FK: poses; Jacobian: the Jacobian; velocity: every twist, as "
                                                    "getFrameVelocity; IK: Pinocchio's FK of every answer, against "
                                                    "its target)")
    base: Union[BasePose, list[BasePose], None] = Field(default=None, description=_BASE_DESC)
    point: Union[Point, None] = Field(default=None, description=_POINT_DESC)
    tool: Union[BasePose, None] = Field(default=None, description=_TOOL_DESC)
    floating_base: Flag = Field(default=False, description=_FLOATING_BASE_DESC)
    normalize: Flag = Field(default=False, description=_NORMALIZE_DESC)


class JointsRequest(QueryRequest):
    """A :class:`QueryRequest` over joint values: ``q`` and the ``limits`` policy."""

    q: JointValues = Field(description=_Q_DESC)
    limits: LimitPolicy = Field(default="report", description=_LIMITS_DESC)
