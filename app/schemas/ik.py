"""Wire schemas of inverse kinematics (``POST /models/{id}/ik``)."""

from __future__ import annotations

from typing import Any, ClassVar, Literal, Union

from pydantic import BaseModel, ConfigDict, Field

from .collision import CollisionPairs
from kinematics.usecases.ik_options import DEFAULT_SETTINGS, CollisionAvoidance, IKOptions, IKSettings, SolutionSet

from .common import QUERY_FIELDS, BasePose, Finite, Flag, Integer, JointValues, Number, QueryRequest, Vector, one_or_all
from .redundancy import RedundancyRequest

_POSE_DESC = ('a pose T_world_link: {"position": [x, y, z], "quaternion": {"w", "x", "y", "z"}}, '
              '{"xyz": [..], "rpy": [..]} or a 4x4 matrix')


class IKTolerance(BaseModel):
    model_config = ConfigDict(extra="forbid")
    position: Finite = Field(default=DEFAULT_SETTINGS.position_tolerance, ge=1e-12,
                             description="metres between the answer's link origin and the target")
    rotation: Finite = Field(default=DEFAULT_SETTINGS.rotation_tolerance, ge=1e-12,
                             description="radians: the angle of R_target^T R (pose mode)")


class IKRequest(QueryRequest, CollisionPairs):  # allow / forbid: the pairs avoid_collisions checks
    #: the request's ``limits`` is the IK branch policy (``IKOptions.solutions.solution_limits``), not the query's
    query_fields: ClassVar[tuple[str, ...]] = tuple(f for f in QUERY_FIELDS if f != "limits")

    link: str | None = Field(default=None, description="the link to place (default: the first leaf link)")
    target: Union[BasePose, list[BasePose]] = Field(description=_POSE_DESC + "; or a list of those (a batch)")
    seed: Union[JointValues, None] = Field(
        default=None, description="starting joint values: one q (vector or name map) for every target, or one per "
                                  "target; default the middle of the limits")
    mode: Literal["pose", "position"] = Field(
        default="pose", description="pose: position and orientation; position: the position only (orientation free)")
    tolerance: IKTolerance = Field(default_factory=IKTolerance)
    max_iterations: Integer = Field(default=DEFAULT_SETTINGS.max_iterations, ge=1, le=10_000,
                                    description="steps per attempt")
    restarts: Integer = Field(default=DEFAULT_SETTINGS.restarts, ge=0, le=10_000,
                          description="attempts from random configurations within the limits after the first")
    random_seed: Integer = Field(default=DEFAULT_SETTINGS.random_seed, ge=0, le=2**63 - 1,
                                 description="the restarts' draws: same inputs, same answers")
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
    avoid_collisions: Flag = Field(
        default=False, description="only answers free of self-collision (the allowed-collision matrix's enabled "
                                   "pairs): with solutions all the colliding ones are left out (counted in "
                                   "colliding); with one the search goes on until a free answer is found, and "
                                   "success holds only for a free one. A model without collision geometry: 422")
    redundancy: Union[RedundancyRequest, None] = Field(
        default=None, description="a 7-joint chain with solutions all: its self-motion (app/schemas/redundancy.py); "
                                  "with solutions one and select alone: the one best point of the self-motion; "
                                  "with avoid_collisions, values leave the colliding solutions out and select "
                                  "answers the best free point (intervals: 422)")

    def ik_options(self, collisions: CollisionAvoidance) -> IKOptions:
        """The library's :class:`~kinematics.usecases.ik_options.IKOptions` of this request, built once;
        ``collisions``: the service's allowed-collision matrix (samples, where it is kept), used when the
        request asks for ``avoid_collisions``."""
        return IKOptions(ik_settings(self), SolutionSet(self.solutions, self.method, self.locked, self.limits,
                                                        RedundancyRequest.spec(self.redundancy)),
                         collisions if self.avoid_collisions else None)


def ik_settings(req: Any) -> IKSettings:
    """The :class:`~kinematics.usecases.ik_options.IKSettings` of a request with ``tolerance`` (and, where it
    has them, ``mode``, ``max_iterations``, ``restarts``, ``random_seed``: the defaults otherwise)."""
    tolerance = req.tolerance
    return IKSettings(getattr(req, "mode", DEFAULT_SETTINGS.mode), tolerance["position"], tolerance["rotation"],
                      **{name: getattr(req, name) for name in ("max_iterations", "restarts", "random_seed")
                         if hasattr(req, name)})


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
    collision_free: Union[bool, list[bool], None] = Field(
        default=None, description="with avoid_collisions: q is free of self-collision")
    verification: IKVerification | None = None

    @staticmethod
    def content(model_id: str, answer: Any) -> dict[str, Any]:
        """The JSON answer of a :class:`kinematics.IKAnswer` (a single target unwrapped)."""
        one = one_or_all(answer.is_batch)
        sol = answer.solution
        verification = None
        if answer.verification is not None:
            v = answer.verification
            verification = {"reference": v["reference"], "position_error": one(v["position_error"]),
                            "rotation_error": one(v["rotation_error"])}
        return {
            "model": model_id, "link": answer.link, "mode": answer.mode, "joint_names": list(answer.model.joint_names),
            "q": one(sol.q), "success": one(sol.success.tolist()), "position_error": one(sol.position_error),
            "rotation_error": one(sol.rotation_error), "iterations": one(sol.iterations.tolist()),
            "collision_free": None if answer.collision_free is None else one(answer.collision_free.tolist()),
            "verification": verification,
        }

    @staticmethod
    def arrays(answer: Any) -> dict[str, Any]:
        """The ``.npz`` answer's arrays of a :class:`kinematics.IKAnswer`."""
        sol = answer.solution
        arrays = {"q": sol.q, "success": sol.success, "position_error": sol.position_error,
                  "rotation_error": sol.rotation_error, "iterations": sol.iterations}
        if answer.collision_free is not None:
            arrays["collision_free"] = answer.collision_free
        return arrays



#: request bodies read by the handlers themselves (JSON or .npy), declared for OpenAPI
IK_EXAMPLES = {
    "one_pose": {"summary": "ur5: put tool0 at a position and orientation",
                 "value": {"link": "tool0", "target": {"xyz": [0.4, 0.1, 0.3], "rpy": [3.14159, 0, 0]}}},
    "batch_position": {"summary": "two targets, position only, seeded, checked with Pinocchio",
                       "value": {"link": "tool0", "mode": "position", "seed": [0, -1, 1, 0, 0, 0], "verify": True,
                                 "target": [{"position": [0.4, 0.2, 0.3], "quaternion": {"w": 1, "x": 0, "y": 0, "z": 0}},
                                            {"xyz": [0.3, -0.3, 0.5], "rpy": [0, 0, 0]}]}},
    "all_collision_free": {"summary": "ur5: every solution free of self-collision",
                           "value": {"link": "tool0", "solutions": "all", "avoid_collisions": True,
                                     "target": {"xyz": [0.4, 0.1, 0.3], "rpy": [3.14159, 0, 0]}}},
}
