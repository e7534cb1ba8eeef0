"""Wire schemas of models: summaries and details, uploads, DH tables, PoE and axes descriptions, screws."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from .common import Flag, Matrix, Vector

class Health(BaseModel):
    status: Literal["ok"] = "ok"
    version: str = Field(description="version of the service")
    pinocchio_version: str = Field(description="version of Pinocchio used by verify=true")
    bundled_models: int = Field(description="number of bundled (catalogue) models")
    warm_up: Literal["pending", "running", "done", "failed"] = Field(
        default="done", description="the compiled kernels' warm-up of the worker that answered: `running` while it "
                                    "loads them (or, on a first start on a machine, compiles them: minutes), when the "
                                    "first request of an operation may be slow; `done` once every operation is ready")


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
TWO_LINK_URDF = """<robot name="two_link">
  <link name="base"/><link name="upper"/><link name="tool"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <axis xyz="0 0 1"/><limit lower="-3.14" upper="3.14" effort="1" velocity="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="tool"/>
    <origin xyz="1 0 0"/><axis xyz="0 0 1"/><limit lower="-3.14" upper="3.14" effort="1" velocity="1"/></joint>
</robot>"""
URDF_EXAMPLES = {"two_link_json": {"summary": "a planar 2R arm (JSON form)",
                                   "value": {"urdf": TWO_LINK_URDF, "name": "two_link"}}}
