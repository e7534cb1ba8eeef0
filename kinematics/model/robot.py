"""The immutable kinematic model: links, joints and the order of q.

A :class:`RobotModel` is built once (from URDF text by :mod:`kinematics.io.urdf`) and never
changed afterwards; it is safe to share between threads. Its arrays are read-only.

``joint_names`` -- the order of q -- is the URDF document order of the moving joints
(revolute, continuous, prismatic, floating, planar) that are not mimic joints (``docs/design.md``,
"q"). A floating or planar joint takes several entries of q and of the velocity vector v, in
Pinocchio's layout (:attr:`RobotModel.layout`): floating ``x, y, z, qx, qy, qz, qw`` (7 values, a
unit quaternion) and 6 velocities (the twist in the joint's child frame, linear first); planar
``x, y, cos θ, sin θ`` (4 values) and 3 velocities (``vx, vy, ωz`` in the child frame). So a
model has ``nq`` joint values and ``nv`` velocities (Jacobian columns); ``dof`` is ``nv``, and
for a model of one-degree-of-freedom joints only, ``nq = nv = dof = len(joint_names)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Mapping, Sequence

import numpy as np

from ..errors import UnknownLinkError, did_you_mean

#: Joint types with one degree of freedom (one entry of q and of v).
ONE_DOF_TYPES = frozenset({"revolute", "continuous", "prismatic"})
#: Joint types with several entries of q and v (Pinocchio's JointModelFreeFlyer and JointModelPlanar).
MULTI_DOF_TYPES = frozenset({"floating", "planar"})
#: Joint types that carry a degree of freedom.
MOVING_TYPES = ONE_DOF_TYPES | MULTI_DOF_TYPES
#: Entries of q (nq) and of the velocity vector (nv) of each moving joint type.
JOINT_NQ = {"revolute": 1, "continuous": 1, "prismatic": 1, "floating": 7, "planar": 4}
JOINT_NV = {"revolute": 1, "continuous": 1, "prismatic": 1, "floating": 6, "planar": 3}
#: Names of the q entries (and of the v entries) of the multi-dof joint types, in order.
Q_COMPONENTS = {"floating": ("x", "y", "z", "qx", "qy", "qz", "qw"), "planar": ("x", "y", "cos", "sin")}
V_COMPONENTS = {"floating": ("vx", "vy", "vz", "wx", "wy", "wz"), "planar": ("vx", "vy", "wz")}
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


@dataclass(frozen=True)
class JointSlot:
    """Where one joint of q sits: its entries ``q[q_start : q_start + nq]`` of the configuration and
    ``v[v_start : v_start + nv]`` of the velocity vector (and the Jacobian's columns)."""

    name: str
    type: str
    q_start: int
    nq: int
    v_start: int
    nv: int

    @property
    def q_slice(self) -> slice:
        return slice(self.q_start, self.q_start + self.nq)

    @property
    def v_slice(self) -> slice:
        return slice(self.v_start, self.v_start + self.nv)

    def as_dict(self) -> dict:
        return {"name": self.name, "type": self.type, "q": [self.q_start, self.q_start + self.nq],
                "v": [self.v_start, self.v_start + self.nv]}


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
        base_model: for a model made by ``floating_base`` (:func:`kinematics.io.floating.with_floating_base`),
            the fixed-base model it was made from; else None.
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
    base_model: "RobotModel | None" = field(default=None, repr=False)

    # -- derived views (computed once, cached) --------------------------------------
    @property
    def dof(self) -> int:
        """Degrees of freedom: the length of the velocity vector, ``nv`` (= ``len(joint_names)``
        when every joint has one degree of freedom)."""
        return self.nv

    @cached_property
    def layout(self) -> tuple[JointSlot, ...]:
        """Per joint of q (``joint_names`` order): its slices of q and of v (Pinocchio's layout)."""
        out, iq, iv = [], 0, 0
        for name in self.joint_names:
            t = self.joint_map[name].type
            out.append(JointSlot(name, t, iq, JOINT_NQ[t], iv, JOINT_NV[t]))
            iq += JOINT_NQ[t]
            iv += JOINT_NV[t]
        return tuple(out)

    @cached_property
    def nq(self) -> int:
        """Length of a configuration q."""
        return sum(s.nq for s in self.layout)

    @cached_property
    def nv(self) -> int:
        """Length of a velocity vector v; the Jacobians' columns."""
        return sum(s.nv for s in self.layout)

    @cached_property
    def multi_dof(self) -> bool:
        """True when the model has a floating or planar joint (then ``nq != nv`` and q has unit parts)."""
        return any(j.type in MULTI_DOF_TYPES for j in self.joints)

    @cached_property
    def slot(self) -> dict[str, JointSlot]:
        return {s.name: s for s in self.layout}

    @cached_property
    def q_labels(self) -> tuple[str, ...]:
        """A name per entry of q: the joint's name, or ``joint.x`` ... ``joint.qw`` for a multi-dof joint."""
        return tuple(s.name if s.type not in Q_COMPONENTS else f"{s.name}.{c}"
                     for s in self.layout for c in (Q_COMPONENTS.get(s.type) or ("",)))

    @cached_property
    def v_labels(self) -> tuple[str, ...]:
        """A name per entry of v (and Jacobian column): the joint's, or ``joint.vx`` ... for a multi-dof joint."""
        return tuple(s.name if s.type not in V_COMPONENTS else f"{s.name}.{c}"
                     for s in self.layout for c in (V_COMPONENTS.get(s.type) or ("",)))

    @cached_property
    def neutral(self) -> np.ndarray:
        """(nq,) the neutral configuration: zeros, identity quaternions (``qw = 1``), planar ``cos = 1``."""
        q = np.zeros(self.nq)
        for s in self.layout:
            if s.type == "floating":
                q[s.q_start + 6] = 1.0
            elif s.type == "planar":
                q[s.q_start + 2] = 1.0
        q.setflags(write=False)
        return q

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
    def link_index(self) -> dict[str, int]:
        """Index of each link name in ``links``."""
        return {name: i for i, name in enumerate(self.links)}

    def link_indices(self, links: Sequence[str] | None) -> np.ndarray:
        """Indices of ``links`` in ``links`` order (None: every link); an unknown name raises
        :class:`~kinematics.errors.UnknownLinkError` with the closest names."""
        if links is None:
            return np.arange(len(self.links))
        index = self.link_index
        out = []
        for name in links:
            if name not in index:
                raise UnknownLinkError(f"unknown link {name!r} (model {self.name!r} has {len(index)} links)"
                                       + did_you_mean(name, self.links, "link names"))
            out.append(index[name])
        return np.array(out, dtype=np.intp)

    @cached_property
    def q_index(self) -> dict[str, int]:
        """Index in q of each joint's (first) entry."""
        if not self.multi_dof:
            return {name: i for i, name in enumerate(self.joint_names)}
        return {s.name: s.q_start for s in self.layout}

    @cached_property
    def moving_joints(self) -> tuple[Joint, ...]:
        """Every moving joint, mimic joints included, document order."""
        return tuple(j for j in self.joints if j.moving)

    def _per_q(self, value) -> list:
        """One value per entry of q: ``value(joint)`` for one-dof joints, ``None`` for each entry of a multi-dof joint."""
        out = []
        for s in self.layout:
            out.extend([value(self.joint_map[s.name])] if s.nq == 1 else [None] * s.nq)
        return out

    @cached_property
    def lower_limits(self) -> np.ndarray:
        """Lower limits (nq,) in q order (-inf for continuous or unlimited joints, and the entries of
        floating and planar joints)."""
        v = self._per_q(lambda j: j.limits.lower if j.limits else -np.inf)
        return frozen_array([-np.inf if x is None else x for x in v])

    @cached_property
    def upper_limits(self) -> np.ndarray:
        """Upper limits (nq,) in q order (+inf for continuous or unlimited joints, and the entries of
        floating and planar joints)."""
        v = self._per_q(lambda j: j.limits.upper if j.limits else np.inf)
        return frozen_array([np.inf if x is None else x for x in v])

    @cached_property
    def continuous(self) -> np.ndarray:
        """(nq,) bool, read-only: which entries of q are continuous joints (unbounded angles)."""
        return self._type_mask({"continuous"})

    @cached_property
    def angular(self) -> np.ndarray:
        """(nq,) bool, read-only: which entries of q are angles of revolute or continuous joints."""
        return self._type_mask({"revolute", "continuous"})

    def _type_mask(self, types: set[str]) -> np.ndarray:
        mask = np.array([bool(x) for x in self._per_q(lambda j: j.type in types)], dtype=bool)
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
        """``n`` random configurations ``(n, nq)`` uniform within the limits.

        Continuous joints (and joints without limits) are drawn in ``[-continuous_range,
        continuous_range]``, i.e. beyond +-pi by default. Floating joints: a position in
        ``[-1, 1]^3`` m and a uniformly random unit quaternion; planar joints: ``x, y`` in
        ``[-1, 1]`` m and an angle uniform in ``[-pi, pi]``.
        """
        rng = np.random.default_rng() if rng is None else rng
        lo = np.where(np.isfinite(self.lower_limits), self.lower_limits, -continuous_range)
        hi = np.where(np.isfinite(self.upper_limits), self.upper_limits, continuous_range)
        Q = rng.uniform(lo, hi, size=(n, self.nq))
        for s in self.layout:
            if s.type == "floating":
                Q[:, s.q_start:s.q_start + 3] = rng.uniform(-1.0, 1.0, (n, 3))
                quat = rng.normal(size=(n, 4))
                Q[:, s.q_start + 3:s.q_start + 7] = quat / np.linalg.norm(quat, axis=1, keepdims=True)
            elif s.type == "planar":
                Q[:, s.q_start:s.q_start + 2] = rng.uniform(-1.0, 1.0, (n, 2))
                theta = rng.uniform(-np.pi, np.pi, n)
                Q[:, s.q_start + 2], Q[:, s.q_start + 3] = np.cos(theta), np.sin(theta)
        return Q
