"""Wire schemas of every IK solution, the chain families and Cartesian paths (``/ik`` with
``solutions: "all"``, ``/ik/family``, ``/ik/path``)."""

from __future__ import annotations

from typing import Any, Literal, Union

from pydantic import BaseModel, ConfigDict, Field

from .common import BasePose, Finite, Flag, JointValues, Number, QueryRequest, Vector, checked, one_or_all

#: targets whose solution records are built between two checks of the request's cancellation
RECORD_TARGETS = 256
from kinematics.usecases.ik_options import CollisionAvoidance, IKOptions, SolutionSet

from .collision import CollisionPairs
from .ik import IKTolerance, ik_settings
from .redundancy import RedundancyPathRequest

_LOCKED_DESC = "joints held at these values, {joint: value}"


class IKSolutionRecord(BaseModel):
    q: Vector = Field(description="joint values (joint_names order)")
    position_error: float = Field(description="metres, FK of q against the target")
    rotation_error: float = Field(description="radians")
    within_limits: bool = Field(description="q inside the joint limits")
    singular: bool = Field(description="a singular configuration (a representative of infinitely many solutions)")


class IKAllResponse(BaseModel):
    model: str
    link: str
    joint_names: list[str]
    method: Literal["analytic", "search"] = Field(description="closed form, or multistart search")
    family: str = Field(description="the chain's family (GET /models/{id}/ik/family)")
    locked: dict[str, float]
    count: Union[int, list[int]] = Field(description="solutions per target")
    solutions: Union[list[IKSolutionRecord], list[list[IKSolutionRecord]]] = Field(
        description="nearest the seed first when a seed is given; for a batch one list per target")
    colliding: Union[int, list[int], None] = Field(
        default=None, description="with avoid_collisions: solutions left out as in self-collision (per target)")
    verification: dict | None = None

    @staticmethod
    def content(model_id: str, answer: Any) -> dict[str, Any]:
        """The JSON answer of a :class:`kinematics.IKAllAnswer`: records per target (a single target unwrapped)."""
        one = one_or_all(answer.is_batch)
        extra = {}
        if getattr(answer, "parameter", None) is not None:  # a redundant chain: its parameter, intervals, best
            extra = {"parameter": {"joint": answer.parameter_name}, "select": answer.select,
                     "intervals": None if answer.intervals is None else one(answer.intervals)}
        return {
            "model": model_id, "link": answer.link, "joint_names": list(answer.model.joint_names),
            "method": answer.method, "family": answer.family, "locked": answer.locked,
            "count": one(answer.count.tolist()),
            "solutions": one([answer.solutions(n) for n in checked(range(len(answer.count)), RECORD_TARGETS)]),
            "colliding": None if answer.colliding is None else one(answer.colliding.tolist()),
            "verification": answer.verification, **extra,
        }

    @staticmethod
    def arrays(answer: Any) -> dict[str, Any]:
        """The ``.npz`` answer's arrays of a :class:`kinematics.IKAllAnswer`, padded with NaN."""
        arrays = {"q": answer.q, "count": answer.count, "within_limits": answer.within_limits,
                  "singular": answer.singular, "position_error": answer.position_error,
                  "rotation_error": answer.rotation_error}
        if answer.colliding is not None:
            arrays["colliding"] = answer.colliding
        if getattr(answer, "parameter", None) is not None:  # a redundant chain: each solution's parameter value
            arrays["parameter"] = answer.parameter
        return arrays


class IKFamilyResponse(BaseModel):
    link: str
    joints: list[str] = Field(description="the free joints of the chain, root first")
    locked: dict[str, float]
    family: str = Field(examples=["three_parallel", "spherical_wrist_parallel_23", "general"])
    closed_form: bool
    max_solutions: int | None = Field(description="the most solutions the structure allows (null: not bounded)")
    subproblems: list[int] = Field(description="the canonical subproblems of its closed form (1-4)")
    reversed: bool = Field(description="solved on the reversed chain (a spherical shoulder)")
    near: bool = Field(description="within a millimetre-scale / milliradian-scale tolerance of the family, not "
                                   "exactly: the closed form seeds Newton steps on the real model")
    redundant: bool = Field(default=False, description="one free joint more than a pose: a self-motion (redundancy)")
    default_parameter: dict | None = Field(default=None, description='{"joint": name}: the redundancy default')
    parameters: list[dict] | None = Field(default=None, description="the parameters giving a closed form, each "
                                                                    "{joint, family}")


class PathStep(BaseModel):
    model_config = ConfigDict(extra="forbid")
    position: Finite = Field(default=0.01, gt=0, description="metres between consecutive targets at most")
    rotation: Finite = Field(default=0.05, gt=0, description="radians between consecutive targets at most")


class IKPathRequest(QueryRequest, CollisionPairs):  # allow / forbid: the pairs avoid_collisions checks
    link: str | None = Field(default=None, description="the link to move (default: the first leaf link)")
    waypoints: list[BasePose] = Field(min_length=2, description="two or more poses, T_world_link")
    seed: Union[JointValues, None] = Field(default=None, description="the start configuration (default: the solution "
                                                                    "of the first target nearest the middle of the limits)")
    step: PathStep = Field(default_factory=PathStep)
    max_joint_step: Finite = Field(default=0.3, gt=0, description="the largest change of any joint between rows (rad or m)")
    tolerance: IKTolerance = Field(default_factory=IKTolerance)
    locked: Union[dict[str, Number], None] = Field(default=None, description=_LOCKED_DESC)
    avoid_collisions: Flag = Field(default=False, description="stop at the first row in self-collision (reason "
                                                               "collision); a model without collision geometry: 422")
    redundancy: Union[RedundancyPathRequest, None] = Field(
        default=None, description="a 7-joint chain: move along its self-motion, the parameter chosen continuously "
                                  "at each target for select (no joint_jump where a continuous in-limit choice "
                                  "exists); a chain that is not redundant: 422")

    def ik_options(self, collisions: CollisionAvoidance) -> IKOptions:
        """The library's :class:`~kinematics.usecases.ik_options.IKOptions` of this request (its tolerances,
        ``locked``, ``redundancy``, and ``collisions`` when it asks for ``avoid_collisions``)."""
        return IKOptions(ik_settings(self),
                         SolutionSet(locked=self.locked, redundancy=RedundancyPathRequest.spec(self.redundancy)),
                         collisions if self.avoid_collisions else None)


class PathStop(BaseModel):
    index: int = Field(description="the target where the path stops")
    reason: Literal["unreachable", "joint_jump", "limits", "collision"]


class IKPathResponse(BaseModel):
    model: str
    link: str
    family: str
    joint_names: list[str]
    q: list[Vector] = Field(description="the achieved rows")
    targets: list[list[list[float]]] = Field(description="every interpolated target (4x4, root frame)")
    position_error: list[float]
    rotation_error: list[float]
    fraction: float = Field(description="share of the path length achieved")
    complete: bool
    stopped: PathStop | None
    max_joint_step: float = Field(description="the largest change of any joint between consecutive rows")

    @staticmethod
    def content(model_id: str, link: str, joint_names, ans: Any) -> dict[str, Any]:
        """The JSON answer of a path (:class:`kinematics.algorithms.ik_path.PathAnswer`) of ``link``."""
        return {
            "model": model_id, "link": link, "family": ans.family, "joint_names": list(joint_names), "q": ans.q,
            "targets": ans.targets, "position_error": ans.position_error, "rotation_error": ans.rotation_error,
            "fraction": ans.fraction, "complete": ans.complete, "stopped": ans.stopped,
            "max_joint_step": ans.max_joint_step,
        }


IK_PATH_EXAMPLES = {
    "straight_line": {"summary": "ur5: tool0 5 cm along x from a start configuration",
                      "value": {"link": "tool0", "seed": [0.3, -1.0, 1.2, -0.5, 0.8, 0.2],
                                "waypoints": [{"xyz": [0.618, 0.365, 0.296], "rpy": [1.78, 0.012, 2.66]},
                                              {"xyz": [0.668, 0.365, 0.296], "rpy": [1.78, 0.012, 2.66]}],
                                "step": {"position": 0.005, "rotation": 0.05}, "max_joint_step": 0.2}},
}

__all__ = ["IKSolutionRecord", "IKAllResponse", "IKFamilyResponse", "PathStep", "IKPathRequest", "PathStop",
           "IKPathResponse", "IK_PATH_EXAMPLES"]
