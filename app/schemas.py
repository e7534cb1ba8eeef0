"""Wire schemas (pydantic): requests, responses and their OpenAPI examples.

Field names follow the API contract (``docs/design.md``). Matrices are row-major
nested lists; quaternions are objects ``{w, x, y, z}``; Jacobians are 6 x dof with the
linear rows first. JSON has no infinity: a condition number at a singularity is ``null``.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal, Union

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, Strict

from kinematics.spatial.reference import Reference

Number = Annotated[float, Strict()]  # a JSON number (not a string, not a boolean)
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


# ---------------------------------------------------------------------- health
class Health(BaseModel):
    status: Literal["ok"] = "ok"
    version: str = Field(description="version of the service")
    pinocchio_version: str = Field(description="version of Pinocchio used by verify=true")
    bundled_models: int = Field(description="number of bundled (catalogue) models")


# ---------------------------------------------------------------------- models
class ModelSummary(BaseModel):
    id: str = Field(examples=["ur5"])
    name: str = Field(examples=["ur5"])
    source: str = Field(description="example-robot-data | preset | upload | dh", examples=["example-robot-data"])
    dof: int | None = Field(description="number of independent joints (null if the bundled file cannot be loaded)")
    error: str | None = Field(default=None, description="why a bundled model cannot be loaded, if it cannot")


class Origin(BaseModel):
    xyz: Vector = Field(description="translation of T_parent_joint, metres")
    rpy: Vector = Field(description="roll, pitch, yaw of T_parent_joint (URDF: R = Rz(yaw) Ry(pitch) Rx(roll))")


class JointLimitsOut(BaseModel):
    lower: float
    upper: float
    effort: float | None = None
    velocity: float | None = None


class MimicOut(BaseModel):
    joint: str = Field(description="the joint followed")
    multiplier: float
    offset: float


class JointInfo(BaseModel):
    name: str
    type: Literal["revolute", "continuous", "prismatic", "fixed", "floating", "planar"]
    axis: Vector = Field(description="unit axis in the joint frame")
    parent: str
    child: str
    origin: Origin
    limits: JointLimitsOut | None = Field(description="null for continuous (or unbounded) joints")
    mimic: MimicOut | None = Field(description="set for a mimic joint: value = multiplier * q[joint] + offset")


class ModelInfo(BaseModel):
    id: str
    name: str
    source: str
    dof: int = Field(description="degrees of freedom: the length of the velocity vector (nv) and the Jacobians' "
                                 "columns; for models of one-dof joints also the length of q")
    nq: int = Field(default=0, description="length of q (7 per floating joint, 4 per planar joint, 1 per other joint)")
    nv: int = Field(default=0, description="length of the velocity vector and the Jacobians' columns (6 per floating "
                                           "joint, 3 per planar joint, 1 per other joint)")
    q_layout: list[dict[str, Any]] = Field(
        default_factory=list, description="per joint of q, in order: name, type, q [start, stop) and v [start, stop) "
                                          "(floating: x, y, z, qx, qy, qz, qw and vx..wz in its child frame; "
                                          "planar: x, y, cos, sin and vx, vy, wz)")
    floating_base: Flag = Field(default=False, description="the model as computed with floating_base: true")
    root: str
    joint_names: list[str] = Field(description="the order of q")
    links: list[str]
    leaf_links: list[str] = Field(description="links with no child: the default links of FK")
    joints: list[JointInfo]
    warnings: list[str]
    urdf_sha256: str
    created: str | None = Field(default=None, description="creation time (stored models)")
    dh_table: dict[str, Any] | None = Field(
        default=None, description="the DH table a DH-built model or DH preset was built from (else null)")
    description: dict[str, Any] | None = Field(
        default=None, description="the product-of-exponentials or zero-configuration axes description a model "
                                  "was built from, in canonical form (else null)")
    format: str = Field(default="urdf", description="what the description was written in: urdf, xacro (expanded), "
                                                   "mjcf (converted), dh, ...; `GET /models/{id}/urdf` is always URDF")
    upload: dict[str, Any] | None = Field(
        default=None, description="how a model read from xacro, MJCF or an archive was sent: `container` (zip, "
                                  "gzip, tar or null), `entry` (the file of the archive), `args` (xacro arguments)")
    note: str | None = Field(
        default=None, description="registrations answered 200 (the same content was already registered): what "
                                  "happened, e.g. the new `name` applied to the stored model")


class URDFUpload(BaseModel):
    """JSON form of ``POST /models`` (the raw XML body is the other form)."""

    model_config = ConfigDict(extra="forbid")
    urdf: str = Field(description="the URDF document (or xacro or MJCF text: told apart by content)")
    name: str | None = Field(default=None, max_length=200, description="display name (default: the robot's name)")
    args: dict[str, str | int | float | bool] | None = Field(
        default=None, description="xacro arguments (`<xacro:arg>`), for xacro text")


class DHJoint(BaseModel):
    """One DH row (``kinematics.io.dh_table`` validates the table and names the field at fault)."""

    model_config = ConfigDict(extra="allow")
    type: str = Field(description="revolute | prismatic (or R | P)", examples=["revolute"])
    a: float = Field(description="link length, metres (modified: a_{i-1})")
    alpha: float = Field(description="link twist (modified: alpha_{i-1}); unit from `angles`")
    d: float = Field(description="link offset, metres (prismatic: its value at q = 0)")
    theta: float = Field(description="joint angle (revolute: its value at q = 0); unit from `angles`")
    name: str | None = Field(default=None, description="joint name (default joint_<i>)")
    limits: list[float] | dict[str, float] | None = Field(
        default=None, description="[lower, upper] (revolute: unit from `angles`; prismatic: metres)")


class DHTable(BaseModel):
    """A Denavit-Hartenberg table, as ``POST /models/dh`` takes it and ``GET /models/{id}/dh`` gives it."""

    model_config = ConfigDict(extra="forbid")
    name: str | None = None
    convention: Literal["standard", "modified"] | None = Field(default="standard", description="null: standard")
    angles: Literal["radians", "degrees"] | None = Field(default="radians", description="null: radians")
    joints: list[DHJoint] = Field(min_length=1)
    base: Matrix | dict[str, Vector] | None = Field(
        default=None, description="T_world_frame0: 4x4, or {xyz, rpy}; default identity")
    tool: Matrix | dict[str, Vector] | None = Field(
        default=None, description="T_frameN_tool: 4x4, or {xyz, rpy}; default identity")


class PoEJointIn(BaseModel):
    """One joint of a product-of-exponentials description (``kinematics.io.poe_model`` validates it)."""

    model_config = ConfigDict(extra="allow")
    S: Vector | None = Field(default=None, description="space screw (w, v), angular first; or give B")
    B: Vector | None = Field(default=None, description="body screw (w, v) in the end-effector frame at q = 0")
    type: str | None = Field(default=None, description="revolute | continuous | prismatic (default: from the screw)")
    name: str | None = Field(default=None, description="joint name (default joint_<i>)")
    limits: list[float] | dict[str, float] | None = Field(default=None, description="[lower, upper]")


class PoEDescriptionIn(BaseModel):
    """A product-of-exponentials description: ``T(q) = exp([S_1] q_1) ... exp([S_n] q_n) M``
    (or ``M exp([B_1] q_1) ... exp([B_n] q_n)``)."""

    model_config = ConfigDict(extra="forbid")
    name: str | None = None
    angles: Literal["radians", "degrees"] | None = Field(default="radians", description="null: radians")
    M: Matrix | dict[str, Vector] = Field(description="end-effector pose at q = 0: 4x4, or {xyz, rpy}")
    joints: list[PoEJointIn]


class AxesJointIn(BaseModel):
    """One joint of a zero-configuration axes description (``kinematics.io.axes_model`` validates it)."""

    model_config = ConfigDict(extra="allow")
    type: str = Field(description="revolute | continuous | prismatic (or R, P)")
    h: Vector = Field(description="unit axis h_i, base coordinates (zero configuration)")
    p: Vector | None = Field(default=None, description="link vector p_{i-1,i} (prismatic: at q = 0); default 0")
    name: str | None = None
    limits: list[float] | dict[str, float] | None = None


class AxesDescriptionIn(BaseModel):
    """Zero-configuration axes (Wen): ``p_0T = p_01 + R_01 p_12 + ... + R_0n p_nT``, ``R_{i-1,i} = rot(h_i, q_i)``."""

    model_config = ConfigDict(extra="forbid")
    name: str | None = None
    angles: Literal["radians", "degrees"] | None = Field(default="radians", description="null: radians")
    joints: list[AxesJointIn] = Field(min_length=1)
    p_nT: Vector | None = Field(default=None, description="tool offset in frame n (default 0)")
    R_nT: Matrix | dict[str, Vector] | None = Field(default=None, description="tool orientation: 3x3 or {rpy}")


class PoEJoint(BaseModel):
    name: str
    type: Literal["revolute", "continuous", "prismatic"]
    screw: Vector = Field(description="space screw S = (w, v) at q = 0, angular first; v = -w x r")
    axis: Vector = Field(description="w: unit axis (prismatic: direction), world frame at q = 0")
    point: Vector = Field(description="r: a point on the axis, world frame (zeros for prismatic)")
    q_index: int = Field(description="column of q driving the joint (the leader's for a mimic joint)")
    multiplier: float = Field(description="joint value = multiplier * q[q_index] + offset")
    offset: float


class Screws(BaseModel):
    model: str
    twist_order: Literal["angular_first"] = "angular_first"
    joint_names: list[str] = Field(description="the order of q")
    joints: list[PoEJoint] = Field(description="every moving joint (mimic joints included), root to leaves")
    home_poses: dict[str, Matrix] = Field(description="M_L = T_world_L(q = 0) for every link")


# ---------------------------------------------------------------------- kinematics
class Quaternion(BaseModel):
    w: Number
    x: Number
    y: Number
    z: Number


class Pose(BaseModel):
    matrix: Matrix = Field(description="T_world_link, 4x4 row-major")
    position: Vector = Field(description="p_world_link, metres")
    quaternion: Quaternion = Field(description="rotation of T_world_link, unit quaternion")
    rpy: Vector = Field(description="roll, pitch, yaw (URDF: R = Rz(yaw) Ry(pitch) Rx(roll))")


class CompactPoses(BaseModel):
    positions: list[Vector] = Field(description="(N, 3) positions, one row per configuration")
    quaternions: list[Vector] = Field(description="(N, 4) unit quaternions, w first (w, x, y, z)")


class FKVerification(BaseModel):
    reference: str = Field(examples=["pinocchio 4.1.0"])
    max_position_error: float = Field(description="metres, over every configuration and link returned")
    max_rotation_error: float = Field(description="largest rotation-matrix entry difference")


class JacobianVerification(BaseModel):
    reference: str
    max_jacobian_error: float = Field(description="largest entry-wise difference")


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
              "one pose per configuration. verify compares the root-frame results with Pinocchio.")


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


class FKRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    q: JointValues = Field(description=_Q_DESC)
    links: Union[Literal["all"], list[str], None] = Field(
        default=None, description='link names; "all" for every link; default: the leaf links')
    verify: Flag = Field(default=False, description="also compare with Pinocchio and report the largest deviations")
    limits: LimitPolicy = Field(default="report", description=_LIMITS_DESC)
    base: Union[BasePose, list[BasePose], None] = Field(default=None, description=_BASE_DESC)
    point: Union[Point, None] = Field(default=None, description=_POINT_DESC)
    tool: Union[BasePose, None] = Field(default=None, description=_TOOL_DESC)
    format: PoseFormat = Field(
        default="pose",
        description="pose: matrix, position, quaternion, rpy per link; matrix: the 4x4 only; "
                    "compact: per link positions (N,3) and quaternions (N,4, w first) arrays")
    floating_base: Flag = Field(default=False, description=_FLOATING_BASE_DESC)
    normalize: Flag = Field(default=False, description=_NORMALIZE_DESC)


class FKResponse(BaseModel):
    model: str
    joint_names: list[str]
    links: list[str] = Field(description="the links returned, in order")
    format: PoseFormat
    poses: Union[dict[str, Pose], list[dict[str, Pose]], dict[str, Matrix], list[dict[str, Matrix]],
                 dict[str, CompactPoses]] = Field(
        description="per link (pose: Pose, matrix: 4x4, compact: arrays); for a batch with format "
                    "pose or matrix, a list with one entry per configuration")
    out_of_limits: Union[list[str], list[list[str]]] = Field(
        description="joints outside their limits (for a batch, one list per configuration)")
    verification: FKVerification | None = None


TaskRepresentationName = Literal["rpy", "zyx", "zyz", "quaternion", "rotvec", "position", "scara", "planar"]
_REPRESENTATION_DESC = ("task vector r = (p, phi): rpy | zyx | zyz | quaternion | rotvec, or a named subset: "
                        "position (px, py, pz), scara (px, py, pz, alpha_z), planar (px, py, phi)")
_ANALYTIC_DESC = ("the analytic Jacobian J_r = dr/dq of this task vector instead of the geometric one "
                  "(POST /models/{id}/task's use case): jacobian is m x dof and r is given; reference must be "
                  "absent or local_world_aligned (J_r is built from that one), verify is not available")


class JacobianRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    q: JointValues = Field(description=_Q_DESC)
    link: str | None = Field(default=None, description="default: the first leaf link")
    reference: References = Field(default=Reference.WORLD, description="world | local | local_world_aligned (Pinocchio's meaning)")
    verify: Flag = False
    limits: LimitPolicy = Field(default="report", description=_LIMITS_DESC)
    base: Union[BasePose, list[BasePose], None] = Field(default=None, description=_BASE_DESC)
    point: Union[Point, None] = Field(default=None, description=_POINT_DESC)
    tool: Union[BasePose, None] = Field(default=None, description=_TOOL_DESC)
    floating_base: Flag = Field(default=False, description=_FLOATING_BASE_DESC)
    normalize: Flag = Field(default=False, description=_NORMALIZE_DESC)
    representation: Union[TaskRepresentationName, None] = Field(default=None, description=_ANALYTIC_DESC)
    components: list[str] | None = Field(default=None, description="with representation: keep these components "
                                         "of the task vector (default all)")


class JacobianResponse(BaseModel):
    model: str
    link: str
    reference: References
    joint_names: list[str] = Field(description="the order of the columns")
    jacobian: Union[Matrix, list[Matrix]] = Field(description="6 x dof, linear rows first (batch: one per configuration); "
                                                  "with representation: J_r = dr/dq, m x dof, rows as components")
    singular_values: Union[Vector, list[Vector]]
    manipulability: Union[float, list[float]] = Field(description="product of the singular values")
    condition_number: Union[float, None, list[Union[float, None]]] = Field(
        description="largest / smallest singular value; null at a singularity (infinite)")
    out_of_limits: Union[list[str], list[list[str]]]
    verification: JacobianVerification | None = None
    representation: str | None = Field(default=None, description="with representation: its name")
    components: list[str] | None = Field(default=None, description="with representation: the rows of jacobian and r")
    r: Union[Vector, list[Vector], None] = Field(default=None, description="with representation: the task vector")


_POSE_DESC = ('a pose T_world_link: {"position": [x, y, z], "quaternion": {"w", "x", "y", "z"}}, '
              '{"xyz": [..], "rpy": [..]} or a 4x4 matrix')


class IKTolerance(BaseModel):
    model_config = ConfigDict(extra="forbid")
    position: Number = Field(default=1e-6, ge=1e-12, description="metres between the answer's link origin and the target")
    rotation: Number = Field(default=1e-6, ge=1e-12, description="radians: the angle of R_target^T R (pose mode)")


class IKRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    link: str | None = Field(default=None, description="the link to place (default: the first leaf link)")
    target: Union[BasePose, list[BasePose]] = Field(description=_POSE_DESC + "; or a list of those (a batch)")
    seed: Union[JointValues, None] = Field(
        default=None, description="starting joint values: one q (vector or name map) for every target, or one per "
                                  "target; default the middle of the limits")
    mode: Literal["pose", "position"] = Field(
        default="pose", description="pose: position and orientation; position: the position only (orientation free)")
    tolerance: IKTolerance = Field(default_factory=IKTolerance)
    max_iterations: Integer = Field(default=100, ge=1, le=10_000, description="steps per attempt")
    restarts: Integer = Field(default=50, ge=0, le=10_000,
                          description="attempts from random configurations within the limits after the first")
    random_seed: Integer = Field(default=0, ge=0, le=2**63 - 1, description="the restarts' draws: same inputs, same answers")
    base: Union[BasePose, list[BasePose], None] = Field(default=None, description=_BASE_DESC)
    point: Union[Point, None] = Field(default=None, description=_POINT_DESC)
    tool: Union[BasePose, None] = Field(default=None, description=_TOOL_DESC)
    verify: Flag = Field(default=False, description="also Pinocchio's FK of every answer, against its target")
    floating_base: Flag = Field(default=False, description=_FLOATING_BASE_DESC)
    normalize: Flag = Field(default=False, description=_NORMALIZE_DESC)
    solutions: Literal["one", "all"] = Field(
        default="one", description="one: a single answer (numerical, or the closed-form solution nearest the seed "
                                   "with method analytic or locked joints); all: every solution")
    method: Literal["auto", "analytic", "numeric"] = Field(
        default="auto", description="auto: the chain's closed form where it has one, else the search (all) or damped "
                                    "least squares (one); analytic: the closed form or a 422; numeric: no closed form")
    locked: Union[dict[str, Number], None] = Field(
        default=None, description="joints held at these values, {joint: value} (a 7-dof arm with one locked is a "
                                  "6-joint chain)")
    limits: Literal["respect", "ignore"] = Field(
        default="respect", description="with solutions all: respect lists every solution inside the limits, each "
                                       "q + 2 pi k copy of a revolute joint included; ignore lists each branch once, "
                                       "revolute angles in (-pi, pi], flagged within_limits")


class IKVerification(BaseModel):
    reference: str = Field(examples=["pinocchio 4.1.0"])
    position_error: Union[float, list[float]] = Field(description="metres, Pinocchio's FK of the answer vs the target")
    rotation_error: Union[float, list[float]] = Field(description="radians")


class IKResponse(BaseModel):
    model: str
    link: str
    mode: Literal["pose", "position"]
    joint_names: list[str] = Field(description="the order of q")
    q: Union[Vector, list[Vector]] = Field(description="the answer (the best found when success is false)")
    success: Union[bool, list[bool]] = Field(
        description="FK of q within the tolerances of the target, and q inside the joint limits")
    position_error: Union[float, list[float]] = Field(description="metres, measured on the answer")
    rotation_error: Union[float, list[float]] = Field(description="radians, measured on the answer")
    iterations: Union[int, list[int]] = Field(description="steps taken, over every attempt")
    verification: IKVerification | None = None


class VelocityRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    q: JointValues = Field(description=_Q_DESC)
    qdot: JointValues = Field(description="joint velocities (rad/s, m/s), in the same form as q: one vector or map "
                                          "per configuration; a mimic joint moves with multiplier * its leader's")
    links: Union[Literal["all"], list[str], None] = Field(default=None, description='link names; default (or "all"): every link')
    verify: Flag = Field(default=False, description="also compare every twist with Pinocchio's getFrameVelocity")
    limits: LimitPolicy = Field(default="report", description=_LIMITS_DESC)
    base: Union[BasePose, list[BasePose], None] = Field(default=None, description=_BASE_DESC + " The base is at rest.")
    point: Union[Point, None] = Field(default=None, description=_POINT_DESC)
    tool: Union[BasePose, None] = Field(default=None, description=_TOOL_DESC)
    floating_base: Flag = Field(default=False, description=_FLOATING_BASE_DESC)
    normalize: Flag = Field(default=False, description=_NORMALIZE_DESC)


class Twists(BaseModel):
    world: Vector = Field(description="twist of the body at the world origin, world axes (linear first)")
    local: Vector = Field(description="velocity of the link origin and angular velocity in the link's axes")
    local_world_aligned: Vector = Field(description="velocity of the link origin and angular velocity, world axes")


class LinkVelocity(BaseModel):
    linear: Vector = Field(description="velocity of the link origin (or of the point / tool origin), world axes, m/s")
    angular: Vector = Field(description="angular velocity of the link, world axes, rad/s")
    twist: Twists


class VelocityVerification(BaseModel):
    reference: str = Field(examples=["pinocchio 4.1.0"])
    max_velocity_error: float = Field(description="largest entry-wise difference of the twists (three references)")


class VelocityResponse(BaseModel):
    model: str
    joint_names: list[str]
    links: list[str] = Field(description="the links returned, in order")
    velocities: Union[dict[str, LinkVelocity], list[dict[str, LinkVelocity]]] = Field(
        description="per link; for a batch, a list with one map per configuration")
    out_of_limits: Union[list[str], list[list[str]]]
    verification: VelocityVerification | None = None


VELOCITY_EXAMPLES = {
    "ur5_tool": {"summary": "UR5 tool0 turning the shoulder, verified",
                 "value": {"q": UR5_HOME, "qdot": [0.5, 0, 0, 0, 0, 0], "links": ["tool0"], "verify": True}},
    "ur5_tcp_batch": {"summary": "a TCP 10 cm along tool0's z, a batch of two",
                      "value": {"q": [[0, 0, 0, 0, 0, 0], UR5_HOME], "qdot": [[0, 1, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0]],
                                "links": ["tool0"], "point": [0, 0, 0.1]}},
}


# ---------------------------------------------------------------------- closed forms and task vectors
SymbolicWhat = Literal["transforms", "jacobian", "task"]
SymbolicFormat = Literal["latex", "python", "c", "text"]


class _SymbolicOptions(BaseModel):
    model_config = ConfigDict(extra="forbid")
    what: list[SymbolicWhat] = Field(default_factory=lambda: ["transforms"], min_length=1,
                                     description="transforms: A_i and T; jacobian: local_world_aligned and world "
                                                 "(6 x n, linear rows first); task: r(q) and J_r = dr/dq")
    format: SymbolicFormat = Field(default="latex", description="latex (compact c_12, s_1 notation), text "
                                   "(strings sympy.sympify reads), python (numpy module), c (C99 functions)")
    simplify: Flag = Field(default=True, description="combine and collect terms (false: the expanded forms, fastest)")
    representation: TaskRepresentationName | None = Field(
        default=None, description=_REPRESENTATION_DESC + "; default rpy (quaternion: the qw >= 0 branch, valid where qw > 0; rotvec: valid below a half turn)")
    components: list[str] | None = Field(default=None, min_length=1, description="keep these components of the task vector")
    variables: Literal["q", "names"] = Field(default="q", description="joint variables q1..qn, or the joint names")
    prefix: str = Field(default="", max_length=64, description="prefix of the C function names")
    timeout: Number | None = Field(default=None, gt=0, description="seconds (at most the service's limit)")


class SymbolicRequest(_SymbolicOptions):
    tip: str | None = Field(default=None, description="the link ending the chain (default: the only leaf link)")


class SymbolicDHRequest(_SymbolicOptions):
    table: dict[str, Any] = Field(description="a DH table (the shape of POST /models/dh) whose a, alpha, d, theta "
                                              "may be parameter names or expressions: \"a1\", \"-d4\", \"pi/2\"")


class JointVariable(BaseModel):
    symbol: str = Field(description="the symbol (q1, ...)")
    joint: str = Field(description="the joint it is")


class CodeFunction(BaseModel):
    name: str
    signature: str
    returns: str


SymbolicMatrix = Union[str, list[list[str]]]


class SymbolicResponse(BaseModel):
    model: str | None = Field(default=None, description="the model id (null for POST /symbolic/dh)")
    root: str
    tip: str
    format: SymbolicFormat
    simplified: bool
    seconds: float = Field(description="time the derivation took")
    joint_variables: list[JointVariable] = Field(description="the order of q")
    parameters: list[str] = Field(description="symbols other than the joint variables (the order of p in C)")
    frames: list[str] = Field(description="the links (DH: frames) that the factors A_i end at")
    T: SymbolicMatrix | None = Field(default=None, description="T_world_tip = base A_1 ... A_n tool (latex: a "
                                     "bmatrix; text: rows of strings)")
    A: list[SymbolicMatrix] | None = Field(default=None, description="the factors A_i")
    base: SymbolicMatrix | None = None
    tool: SymbolicMatrix | None = None
    jacobian: dict[str, SymbolicMatrix] | None = Field(default=None, description="per reference, 6 x n")
    representation: str | None = None
    components: list[str] | None = None
    r: SymbolicMatrix | None = Field(default=None, description="the task vector (a column)")
    J_r: SymbolicMatrix | None = Field(default=None, description="dr/dq")
    code: str | None = Field(default=None, description="python / c: the generated source")
    functions: list[CodeFunction] | None = None


class TaskRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    q: JointValues = Field(description=_Q_DESC)
    link: str | None = Field(default=None, description="default: the first leaf link")
    representation: TaskRepresentationName = Field(default="rpy", description=_REPRESENTATION_DESC)
    components: list[str] | None = Field(default=None, min_length=1, description="keep these components (default all)")
    limits: LimitPolicy = Field(default="report", description=_LIMITS_DESC)
    base: Union[BasePose, list[BasePose], None] = Field(default=None, description=_BASE_DESC)


class TaskResponse(BaseModel):
    model: str
    link: str
    representation: str
    components: list[str]
    joint_names: list[str] = Field(description="the order of the columns of J_r")
    r: Union[Vector, list[Vector]] = Field(description="the task vector (batch: one per configuration)")
    J_r: Union[Matrix, list[Matrix]] = Field(description="m x dof analytic Jacobian dr/dq = blockdiag(I, E^-1) J")
    out_of_limits: Union[list[str], list[list[str]]]


class WorkspaceRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    link: str | None = Field(default=None, description="the link (default: the first leaf link)")
    point: Union[Point, None] = Field(default=None, description=_POINT_DESC)
    tool: Union[BasePose, None] = Field(default=None, description=_TOOL_DESC)
    samples: Integer = Field(default=100_000, ge=1, description="configurations drawn uniformly within the joint limits "
                                                             "(bounded by the max_workspace_samples setting)")
    random_seed: Integer = Field(default=0, ge=0, le=2**63 - 1, description="seed of the draws: same inputs, same answer")
    voxel: Number | None = Field(default=None, gt=0, description="edge of the occupancy-grid cells, metres (default: "
                                                                "chosen so that the bounding box has about samples/16 cells)")
    measure: Literal["pose", "position"] = Field(
        default="pose", description="manipulability: product of the singular values of the 6 x k local_world_aligned "
                                    "Jacobian over the k joints on the path (pose) or of its 3 position rows (position)")


class BoundingBox(BaseModel):
    min: Vector
    max: Vector


class ConvergenceStep(BaseModel):
    samples: int
    volume: float | None = Field(default=None, description="m³ (spatial workspaces)")
    area: float | None = Field(default=None, description="m² (planar workspaces)")


class ManipulabilityStats(BaseModel):
    min: float
    mean: float
    max: float


class WorkspaceResponse(BaseModel):
    model: str
    link: str
    samples: int
    random_seed: int
    measure: Literal["pose", "position"]
    dimension: int = Field(description="3: the samples fill space; 2: they lie in a plane (a planar arm); 1, 0")
    bounding_box: BoundingBox
    reach: float = Field(description="largest distance of a sample from the root frame's origin, metres")
    volume: float = Field(description="occupancy-grid estimate, m³ (0 for a planar workspace)")
    area: float | None = Field(default=None, description="planar workspaces: the area, m²")
    convergence: list[ConvergenceStep] = Field(description="the estimate over the first N/4, N/2 and N samples")
    voxel: float = Field(description="the cell edge asked for or chosen, metres")
    cell: Vector = Field(description="the grid's cell edges along its axes (each <= voxel, so whole cells tile the "
                                     "bounding box; 0 along a flat axis)")
    occupied_voxels: int = Field(description="cells holding a sample (the dexterity map's size; its cells and best "
                                             "manipulability come with Accept: application/x-npz)")
    manipulability: ManipulabilityStats


WORKSPACE_EXAMPLES = {
    "ur5": {"summary": "UR5 tool0, 100,000 samples", "value": {"link": "tool0", "samples": 100000}},
    "ur5_tcp": {"summary": "a TCP 10 cm along tool0's z, position manipulability, 5 cm cells",
                "value": {"link": "tool0", "point": [0, 0, 0.1], "samples": 200000, "voxel": 0.05,
                          "measure": "position", "random_seed": 7}},
}


class Problem(BaseModel):
    """An error (``application/problem+json``)."""

    model_config = ConfigDict(extra="allow")
    type: str
    title: str
    status: int
    detail: str
    field: str | None = None


# ---------------------------------------------------------------------- examples
FK_EXAMPLES = {
    "ur5_single": {
        "summary": "UR5, one configuration",
        "value": {"q": UR5_HOME, "links": ["tool0"], "verify": True},
    },
    "ur5_batch": {
        "summary": "UR5, a batch of two",
        "value": {"q": [[0, 0, 0, 0, 0, 0], UR5_HOME], "links": ["tool0", "wrist_3_link"]},
    },
    "ur5_name_map": {
        "summary": "UR5, q as a name map, every link",
        "value": {"q": {"shoulder_pan_joint": 0.1, "shoulder_lift_joint": -1.2, "elbow_joint": 1.0,
                        "wrist_1_joint": 0.0, "wrist_2_joint": 1.57, "wrist_3_joint": 0.0}, "links": "all"},
    },
    "ur5_compact": {
        "summary": "UR5, a batch in compact form",
        "value": {"q": [[0, 0, 0, 0, 0, 0], UR5_HOME], "format": "compact"},
    },
}
JACOBIAN_EXAMPLES = {
    "ur5_world": {
        "summary": "UR5 tool0, world reference, verified",
        "value": {"q": UR5_HOME, "link": "tool0", "reference": "world", "verify": True},
    },
    "ur5_batch_lwa": {
        "summary": "UR5, a batch, local_world_aligned",
        "value": {"q": [[0, 0, 0, 0, 0, 0], UR5_HOME], "link": "tool0", "reference": "local_world_aligned"},
    },
    "ur5_analytic_rpy": {
        "summary": "UR5 tool0, analytic Jacobian of (px, py, pz, roll, pitch, yaw)",
        "value": {"q": [0, -1.2, 1.5, -0.4, 1.1, 0.3], "link": "tool0", "representation": "rpy"},
    },
}
DH_EXAMPLE_TABLE = {
    "name": "example_rrp",
    "convention": "standard",
    "angles": "degrees",
    "joints": [
        {"type": "revolute", "a": 0, "alpha": -90, "d": 0.412, "theta": 0, "name": "j1", "limits": [-170, 170]},
        {"type": "revolute", "a": 0, "alpha": 90, "d": 0.154, "theta": 0},
        {"type": "prismatic", "a": 0, "alpha": 0, "d": 0, "theta": -90, "limits": [0.3, 1.2]},
    ],
    "base": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],
    "tool": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.1], [0, 0, 0, 1]],
}
DH_EXAMPLES = {"rrp_standard": {"summary": "an RRP arm, standard DH, degrees", "value": DH_EXAMPLE_TABLE}}
POE_EXAMPLES = {"mr_3r_spatial": {"summary": "the 3R spatial chain of Modern Robotics (L1 = 0.6, L2 = 0.4)", "value": {
    "name": "mr_3r_spatial", "M": [[0, 0, 1, 0.6], [0, 1, 0, 0], [-1, 0, 0, -0.4], [0, 0, 0, 1]],
    "joints": [{"S": [0, 0, 1, 0, 0, 0]}, {"S": [0, -1, 0, 0, 0, -0.6]}, {"S": [1, 0, 0, 0, -0.4, 0]}]}}}
AXES_EXAMPLES = {"wen_scara": {"summary": "Wen's SCARA (RRRP; l1 = 0.4, l2 = 0.3, l3 = 0.1)", "value": {
    "name": "wen_scara", "joints": [{"type": "R", "h": [0, 0, 1], "p": [0, 0, 0]},
                                    {"type": "R", "h": [0, 0, 1], "p": [0, 0.4, 0]},
                                    {"type": "R", "h": [0, 0, 1], "p": [0, 0.3, 0]},
                                    {"type": "P", "h": [0, 0, 1], "p": [0, 0, 0.1]}], "p_nT": [0, 0, 0]}}}
SYMBOLIC_EXAMPLES = {
    "latex_transforms": {"summary": "UR5: T and the factors A_i in LaTeX",
                         "value": {"tip": "tool0", "what": ["transforms"]}},
    "task_text": {"summary": "UR5: the task vector (px, py, pz) and dr/dq as text",
                  "value": {"tip": "tool0", "what": ["task"], "representation": "position", "format": "text"}},
    "c_code": {"summary": "UR5: C functions of T and the Jacobians",
               "value": {"tip": "tool0", "what": ["transforms", "jacobian"], "format": "c", "prefix": "ur5_"}},
}
SYMBOLIC_DH_EXAMPLES = {"scara_symbolic": {"summary": "the SCARA of the notes, symbolic lengths (d4 < 0)", "value": {
    "what": ["transforms", "task"], "representation": "scara", "table": {"joints": [
        {"type": "R", "a": "a1", "alpha": 0, "d": "d1", "theta": 0},
        {"type": "R", "a": "a2", "alpha": 0, "d": 0, "theta": 0},
        {"type": "P", "a": 0, "alpha": 0, "d": 0, "theta": 0},
        {"type": "R", "a": 0, "alpha": "pi", "d": "d4", "theta": 0}]}}}}
TWO_LINK_URDF = """<robot name="two_link">
  <link name="base"/><link name="upper"/><link name="tool"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <axis xyz="0 0 1"/><limit lower="-3.14" upper="3.14" effort="1" velocity="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="tool"/>
    <origin xyz="1 0 0"/><axis xyz="0 0 1"/><limit lower="-3.14" upper="3.14" effort="1" velocity="1"/></joint>
</robot>"""
URDF_EXAMPLES = {"two_link_json": {"summary": "a planar 2R arm (JSON form)",
                                   "value": {"urdf": TWO_LINK_URDF, "name": "two_link"}}}

#: request bodies read by the handlers themselves (JSON or .npy), declared for OpenAPI
IK_EXAMPLES = {
    "one_pose": {"summary": "ur5: put tool0 at a position and orientation",
                 "value": {"link": "tool0", "target": {"xyz": [0.4, 0.1, 0.3], "rpy": [3.14159, 0, 0]}}},
    "batch_position": {"summary": "two targets, position only, seeded, checked with Pinocchio",
                       "value": {"link": "tool0", "mode": "position", "seed": [0, -1, 1, 0, 0, 0], "verify": True,
                                 "target": [{"position": [0.4, 0.2, 0.3], "quaternion": {"w": 1, "x": 0, "y": 0, "z": 0}},
                                            {"xyz": [0.3, -0.3, 0.5], "rpy": [0, 0, 0]}]}},
}

REQUEST_SCHEMAS: tuple[type[BaseModel], ...] = (FKRequest, JacobianRequest, IKRequest, VelocityRequest,
                                                WorkspaceRequest, URDFUpload, DHTable, PoEDescriptionIn,
                                                AxesDescriptionIn, Problem)
