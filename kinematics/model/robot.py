"""The immutable kinematic model: links, joints and the order of q.

A :class:`RobotModel` is built once (from URDF text by :mod:`kinematics.io.urdf`) and never
changed afterwards; it is safe to share between threads. Its arrays are read-only.

``joint_names`` -- the order of q -- is the URDF document order of the moving joints
(revolute, continuous, prismatic) that are not mimic joints (``docs/design.md``, "q").
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Mapping

import numpy as np

#: Joint types that carry a degree of freedom.
MOVING_TYPES = frozenset({"revolute", "continuous", "prismatic"})
#: Joint types the product supports.
SUPPORTED_TYPES = MOVING_TYPES | {"fixed"}


def frozen_array(a) -> np.ndarray:
    """A read-only float64 copy of ``a`` (the arrays of immutable models and tables)."""
    arr = np.array(a, dtype=float)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True)
class Limits:
    """Position limits of a joint (radians or metres); effort and velocity when given."""

    lower: float
    upper: float
    effort: float | None = None
    velocity: float | None = None


@dataclass(frozen=True)
class Mimic:
    """``q_joint = multiplier * q_leader + offset``; ``leader`` names the mimicked joint."""

    leader: str
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True)
class Visual:
    """Primitive visual geometry of a link (meshes are recorded by kind only, never opened)."""

    kind: str  # box | cylinder | sphere | mesh
    origin: np.ndarray  # T_link_visual, 4x4
    size: tuple[float, ...] = ()  # box: (x, y, z); cylinder: (radius, length); sphere: (radius,)


@dataclass(frozen=True)
class Joint:
    """One URDF joint. ``origin`` is ``T_parent_joint`` (4x4); ``axis`` a unit vector in the joint frame."""

    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray
    limits: Limits | None = None
    mimic: Mimic | None = None

    @property
    def moving(self) -> bool:
        return self.type in MOVING_TYPES


@dataclass(frozen=True, eq=False)
class RobotModel:
    """An immutable kinematic tree.

    Attributes:
        name: the robot's name.
        links: link names, URDF document order.
        joints: joints, URDF document order.
        root: the root link (its frame is the world frame).
        joint_names: names of the independent moving joints: the order of q.
        content_hash: SHA-256 (hex) of the URDF text the model was built from.
        urdf: that URDF text.
        warnings: things a user should know (e.g. a mimic naming a joint the file lacks).
        visuals: primitive visual geometry per link name.
        format: what the description was written in: ``urdf``, ``xacro`` (expanded to ``urdf``),
            ``mjcf`` (turned into ``urdf``), ``dh``; the ``urdf`` text is always URDF.
    """

    name: str
    links: tuple[str, ...]
    joints: tuple[Joint, ...]
    root: str
    joint_names: tuple[str, ...]
    content_hash: str
    urdf: str = field(repr=False)
    warnings: tuple[str, ...] = ()
    visuals: Mapping[str, tuple[Visual, ...]] = field(default_factory=dict, repr=False)
    format: str = "urdf"

    # -- derived views (computed once, cached) --------------------------------------
    @property
    def dof(self) -> int:
        return len(self.joint_names)

    @cached_property
    def joint_map(self) -> dict[str, Joint]:
        return {j.name: j for j in self.joints}

    @cached_property
    def parent_joint(self) -> dict[str, Joint]:
        """The joint whose child is the link, for every link but the root."""
        return {j.child: j for j in self.joints}

    @cached_property
    def children(self) -> dict[str, tuple[Joint, ...]]:
        out: dict[str, list[Joint]] = {name: [] for name in self.links}
        for j in self.joints:
            out[j.parent].append(j)
        return {k: tuple(v) for k, v in out.items()}

    @cached_property
    def leaf_links(self) -> tuple[str, ...]:
        """Links with no child joint, in document order."""
        return tuple(name for name in self.links if not self.children[name])

    @cached_property
    def q_index(self) -> dict[str, int]:
        return {name: i for i, name in enumerate(self.joint_names)}

    @cached_property
    def moving_joints(self) -> tuple[Joint, ...]:
        """Every moving joint, mimic joints included, document order."""
        return tuple(j for j in self.joints if j.moving)

    @cached_property
    def lower_limits(self) -> np.ndarray:
        """Lower limits in q order (-inf for continuous or unlimited joints)."""
        return frozen_array(
            [self.joint_map[n].limits.lower if self.joint_map[n].limits else -np.inf for n in self.joint_names]
        )

    @cached_property
    def upper_limits(self) -> np.ndarray:
        """Upper limits in q order (+inf for continuous or unlimited joints)."""
        return frozen_array(
            [self.joint_map[n].limits.upper if self.joint_map[n].limits else np.inf for n in self.joint_names]
        )

    @cached_property
    def continuous(self) -> np.ndarray:
        """(dof,) bool, read-only: which joints of q are continuous (unbounded angles)."""
        return self._type_mask({"continuous"})

    @cached_property
    def angular(self) -> np.ndarray:
        """(dof,) bool, read-only: which joints of q are angles (revolute or continuous)."""
        return self._type_mask({"revolute", "continuous"})

    def _type_mask(self, types: set[str]) -> np.ndarray:
        mask = np.array([self.joint_map[n].type in types for n in self.joint_names], dtype=bool)
        mask.setflags(write=False)
        return mask

    def topological_links(self) -> tuple[str, ...]:
        """Links ordered so that every parent comes before its children (depth first)."""
        order: list[str] = []
        stack = [self.root]
        while stack:
            link = stack.pop()
            order.append(link)
            stack.extend(j.child for j in reversed(self.children[link]))
        return tuple(order)

    def path_joints(self, link: str) -> tuple[Joint, ...]:
        """Joints from the root to ``link``, in order (fixed joints included)."""
        path = []
        while link != self.root:
            j = self.parent_joint[link]
            path.append(j)
            link = j.parent
        return tuple(reversed(path))

    def resolve_mimic(self, joint: Joint) -> tuple[str, float, float] | None:
        """``(independent_joint, multiplier, offset)`` of a mimic joint, chains of mimics composed."""
        if joint.mimic is None:
            return None
        mult, off = 1.0, 0.0
        j = joint
        while j.mimic is not None:
            # q_j = m * q_leader + o ; compose with the outer expression
            off = off + mult * j.mimic.offset
            mult = mult * j.mimic.multiplier
            j = self.joint_map[j.mimic.leader]
        return j.name, mult, off

    def sample_configurations(self, n: int, rng: np.random.Generator | None = None, continuous_range: float = 2 * np.pi) -> np.ndarray:
        """``n`` random configurations ``(n, dof)`` uniform within the limits.

        Continuous joints (and joints without limits) are drawn in ``[-continuous_range,
        continuous_range]``, i.e. beyond +-pi by default.
        """
        rng = np.random.default_rng() if rng is None else rng
        lo = np.where(np.isfinite(self.lower_limits), self.lower_limits, -continuous_range)
        hi = np.where(np.isfinite(self.upper_limits), self.upper_limits, continuous_range)
        return rng.uniform(lo, hi, size=(n, self.dof))
