"""Wire schemas of self-collision (``POST /models/{id}/collision``, ``GET /models/{id}/collision/matrix``)."""

from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import BaseModel, ConfigDict, Field

from .common import _FLOATING_BASE_DESC, _NORMALIZE_DESC, _Q_DESC, Finite, Flag, JointValues, Number, ToQuery, Vector

__all__ = ["CollisionRequest", "CollisionResponse", "ClosestPair", "CollisionMatrixResponse", "DisabledPair",
           "COLLISION_EXAMPLES", "CollisionPairs", "CollisionPairsRequest", "CollisionPairsResponse", "EnabledPair"]

LinkPair = list[str]
#: the most pairs one list may name (a model of MAX_LINKS links has fewer than that many pairs anyway)
MAX_USER_PAIRS = 10_000
UserPair = Annotated[list[str], Field(min_length=2, max_length=2)]


class CollisionPairs(BaseModel):
    """The link pairs a request sets on the model's allowed-collision matrix (over the model's own
    settings, ``PUT /models/{id}/collision/pairs``: a pair named here takes this choice)."""

    allow: list[UserPair] = Field(default_factory=list, max_length=MAX_USER_PAIRS,
                                  description="link pairs never checked for self-collision (reason user): a gripper "
                                              "holding a tool, a calibration rig")
    forbid: list[UserPair] = Field(default_factory=list, max_length=MAX_USER_PAIRS,
                                   description="link pairs always checked, even those the matrix disables (a pair "
                                               "the sampling called never that a task reaches)")

    def user_pairs(self) -> dict:
        return {"allow": [list(p) for p in self.allow], "forbid": [list(p) for p in self.forbid]}


class CollisionRequest(ToQuery, CollisionPairs):
    model_config = ConfigDict(extra="forbid")
    q: JointValues = Field(description=_Q_DESC)
    distance: Flag = Field(default=False, description="also the minimum distance over the checked pairs, the closest "
                                                      "pair and its witness points")
    margin: Finite = Field(default=0.0, ge=0.0, le=10.0, description="metres: pairs closer than this count as colliding")
    floating_base: Flag = Field(default=False, description=_FLOATING_BASE_DESC)
    normalize: Flag = Field(default=False, description=_NORMALIZE_DESC)


class ClosestPair(BaseModel):
    links: LinkPair = Field(description="the two links, in the model's link order")
    points: list[Vector] = Field(description="the witness points on each link's geometry, root frame, metres")


class CollisionResponse(BaseModel):
    model: str
    joint_names: list[str]
    colliding: Union[bool, list[bool]] = Field(description="per configuration for a batch")
    pairs: Union[list[LinkPair], list[list[LinkPair]]] = Field(description="the link pairs in collision (a list per "
                                                                           "configuration for a batch)")
    min_distance: Union[float, None, list[Union[float, None]]] = Field(
        default=None, description="with distance: metres, the minimum over the checked pairs (negative: penetration "
                                  "depth where coal measures it; null when no pair is checked)")
    closest: Union[ClosestPair, None, list[Union[ClosestPair, None]]] = Field(
        default=None, description="with distance: the pair achieving min_distance and its witness points")
    checked_pairs: int = Field(description="pairs checked: those the allowed-collision matrix leaves enabled")
    links: list[str] = Field(description="links with collision geometry")
    warnings: list[str] = Field(description="collision geometry left out (meshes not opened, unreadable shapes)")


class DisabledPair(BaseModel):
    links: LinkPair
    reason: Literal["adjacent", "never", "always", "user"]


class EnabledPair(BaseModel):
    links: LinkPair
    reason: Literal["user"]


class CollisionMatrixResponse(BaseModel):
    model: str
    links: list[str] = Field(description="links with collision geometry")
    disabled: list[DisabledPair] = Field(description="pairs never checked, each with its reason")
    enabled: list[EnabledPair] = Field(default_factory=list, description="pairs a user forbids that the matrix "
                                                                         "would disable: checked all the same")
    samples: int = Field(description="random configurations the never and always reasons were sampled from")


class CollisionPairsRequest(CollisionPairs):
    model_config = ConfigDict(extra="forbid")


class CollisionPairsResponse(BaseModel):
    model: str
    allow: list[LinkPair] = Field(description="the model's pairs never checked (reason user)")
    forbid: list[LinkPair] = Field(description="the model's pairs always checked")


COLLISION_EXAMPLES = {
    "one": {"summary": "one configuration", "value": {"q": [0, -1.0, 2.9, 0, 0, 0]}},
    "batch": {"summary": "a batch, with distances and a margin",
              "value": {"q": [[0, -1.57, 0, -1.57, 0, 0], [0, -1.0, 2.9, 0, 0, 0]], "distance": True, "margin": 0.01}},
    "pairs": {"summary": "a pair allowed (not checked) and one forbidden (checked though the matrix disables it)",
              "value": {"q": [0, -1.0, 2.9, 0, 0, 0], "allow": [["shoulder_link", "wrist_2_link"]],
                        "forbid": [["wrist_1_link", "wrist_3_link"]]}},
}
