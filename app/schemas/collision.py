"""Wire schemas of self-collision (``POST /models/{id}/collision``, ``GET /models/{id}/collision/matrix``)."""

from __future__ import annotations

from typing import Literal, Union

from pydantic import BaseModel, ConfigDict, Field

from .common import _FLOATING_BASE_DESC, _NORMALIZE_DESC, _Q_DESC, Finite, Flag, JointValues, Number, ToQuery, Vector

__all__ = ["CollisionRequest", "CollisionResponse", "ClosestPair", "CollisionMatrixResponse", "DisabledPair",
           "COLLISION_EXAMPLES"]

LinkPair = list[str]


class CollisionRequest(ToQuery, BaseModel):
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


class CollisionMatrixResponse(BaseModel):
    model: str
    links: list[str] = Field(description="links with collision geometry")
    disabled: list[DisabledPair] = Field(description="pairs never checked, each with its reason")
    samples: int = Field(description="random configurations the never and always reasons were sampled from")


COLLISION_EXAMPLES = {
    "one": {"summary": "one configuration", "value": {"q": [0, -1.0, 2.9, 0, 0, 0]}},
    "batch": {"summary": "a batch, with distances and a margin",
              "value": {"q": [[0, -1.57, 0, -1.57, 0, 0], [0, -1.0, 2.9, 0, 0, 0]], "distance": True, "margin": 0.01}},
}
