"""Wire schemas of closed forms (``POST /models/{id}/symbolic``, ``POST /symbolic/dh``) and task
vectors (``POST /models/{id}/task``)."""

from __future__ import annotations

from typing import Any, Literal, Union

from pydantic import BaseModel, ConfigDict, Field

from .common import (ToQuery, _BASE_DESC, _LIMITS_DESC, _Q_DESC, _REPRESENTATION_DESC, BasePose, Finite, Flag,
                     JointValues, LimitPolicy, Matrix, Number, TaskRepresentationName, Vector)

#: the shortest time limit a closed-form request may ask for, seconds (a worker process starts first)
MIN_TIMEOUT = 0.1

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
    timeout: Finite | None = Field(default=None, ge=MIN_TIMEOUT, le=3600,
                                   description=f"seconds, at least {MIN_TIMEOUT:g} (the service's limit "
                                               "KIN_SYMBOLIC_TIMEOUT applies when it is shorter); a derivation over "
                                               "this request's own timeout is a 422, over the service's a 503")


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


class TaskRequest(ToQuery, BaseModel):
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



SYMBOLIC_EXAMPLES = {
    "latex_transforms": {"summary": "UR5: T and the factors A_i in LaTeX",
                         "value": {"tip": "tool0", "what": ["transforms"]}},
    "task_text": {"summary": "UR5: the task vector (px, py, pz) and dr/dq as text",
                  "value": {"tip": "tool0", "what": ["task"], "representation": "position", "format": "text"}},
    "c_code": {"summary": "UR5: C functions of T and the Jacobians",
               "value": {"tip": "tool0", "what": ["transforms", "jacobian"], "format": "c", "prefix": "ur5_"}},
}
SYMBOLIC_DH_EXAMPLES = {"scara_symbolic": {"summary": "De Luca's SCARA, symbolic lengths (d4 < 0)", "value": {
    "what": ["transforms", "task"], "representation": "scara", "table": {"joints": [
        {"type": "R", "a": "a1", "alpha": 0, "d": "d1", "theta": 0},
        {"type": "R", "a": "a2", "alpha": 0, "d": 0, "theta": 0},
        {"type": "P", "a": 0, "alpha": 0, "d": 0, "theta": 0},
        {"type": "R", "a": 0, "alpha": "pi", "d": "d4", "theta": 0}]}}}}
