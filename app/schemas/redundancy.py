"""Wire schema of a redundant (7-joint) chain's self-motion: the ``redundancy`` field of ``POST
/models/{id}/ik`` with ``solutions: "all"`` and of ``POST /models/{id}/ik/path``."""

from __future__ import annotations

from typing import Literal, Union

from pydantic import BaseModel, ConfigDict, Field

from .common import Flag, Number


class RedundancyParameter(BaseModel):
    model_config = ConfigDict(extra="forbid")
    joint: str = Field(description="a free joint of the chain: its value runs along the self-motion")


_PARAMETER_DESC = 'what runs along the self-motion: {"joint": name} (default: the family answer\'s default_parameter)'
_OBJECTIVES = Literal["nearest", "margin", "manipulability"]


class _Spec(BaseModel):
    def as_spec(self) -> dict:
        """The library's ``redundancy`` map."""
        out = self.model_dump(exclude_none=True)
        if isinstance(self.parameter, RedundancyParameter):
            out["parameter"] = {"joint": self.parameter.joint}
        return out

    @classmethod
    def spec(cls, field: "_Spec | dict | None") -> dict | None:
        """The library's ``redundancy`` map of a request's field (None: none; the service reads bodies
        with ``model_construct``, so the field may be the validated dict)."""
        return None if field is None else cls.model_validate(field).as_spec()


class RedundancyRequest(_Spec):
    model_config = ConfigDict(extra="forbid")
    parameter: Union[RedundancyParameter, Literal["sew"], None] = Field(default=None, description=_PARAMETER_DESC)
    values: Union[list[Number], list[list[Number]], None] = Field(
        default=None, description="parameter values: every solution at each (one list for every target, or one "
                                  "list per target); each solution carries its parameter")
    intervals: Flag = Field(default=False, description="answer per target the in-limit ranges of the parameter "
                                                       "({from, to, branches})")
    select: _OBJECTIVES | None = Field(
        default=None, description="the one best in-limit solution over the whole self-motion: nearest the seed, "
                                  "largest normalised limit margin, or largest manipulability")


class RedundancyPathRequest(_Spec):
    model_config = ConfigDict(extra="forbid")
    parameter: Union[RedundancyParameter, None] = Field(default=None, description=_PARAMETER_DESC)
    select: _OBJECTIVES = Field(
        description="the objective kept along the path: nearest (the least step from the previous row), margin "
                    "(the largest normalised limit margin) or manipulability, among the choices that continue the "
                    "previous row's branch within max_joint_step")


__all__ = ["RedundancyParameter", "RedundancyRequest", "RedundancyPathRequest"]
