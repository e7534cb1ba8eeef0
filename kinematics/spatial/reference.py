"""The three reference frames in which a Jacobian or a twist is expressed (Pinocchio's names).

| value | meaning |
|---|---|
| ``world`` | twist of the body measured at the world origin, in world axes |
| ``local`` | twist in the link's own frame |
| ``local_world_aligned`` | velocity of the link origin and angular velocity, in world axes |

Every 6-vector the library returns puts the **linear part first**, then the angular part.
"""

from __future__ import annotations

from enum import StrEnum

from ..errors import KinematicsError


class Reference(StrEnum):
    """A Jacobian's reference frame; compares equal to its string value (``"world"``, ...)."""

    WORLD = "world"
    LOCAL = "local"
    LOCAL_WORLD_ALIGNED = "local_world_aligned"


#: The reference names, in the order the documentation lists them.
REFERENCES: tuple[str, ...] = tuple(r.value for r in Reference)


def parse_reference(value: str) -> Reference:
    """``value`` as a :class:`Reference`; anything else is a :class:`~kinematics.errors.KinematicsError`
    listing the three names."""
    try:
        return Reference(value)
    except ValueError:
        raise KinematicsError(f"unknown reference {value!r}; expected one of {', '.join(REFERENCES)}") from None
