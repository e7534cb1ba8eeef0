"""IK's options as frozen objects, beside :class:`~kinematics.usecases.query.Query`.

A :class:`Query` says which frame of which model; an IK request adds how to solve, and these
objects hold it, each default written once, here:

- :class:`IKSettings`: the solver's settings, what counts as a solution and how hard the search
  tries (``mode``, the tolerances, ``max_iterations``, ``restarts``, ``random_seed``);
- :class:`SolutionSet`: which solutions are asked for: ``solutions`` (``one`` or ``all``),
  ``method``, ``locked`` joints and ``solution_limits``, the branch policy: ``respect`` lists the
  solutions inside the joint limits (each ``q + 2 pi k`` copy of a revolute joint), ``ignore``
  lists each branch once, angles in (-pi, pi]; and, for a redundant (7-joint) chain, ``redundancy``
  (:class:`~kinematics.algorithms.ik_redundant.Redundancy`: where along its self-motion). (The query's ``limits``, ``report`` / ``refuse``,
  is another policy: what to do with *given* joint values out of their limits. The service's
  and the library's keyword for this one stays ``limits``; the object names it
  ``solution_limits`` so that the two never meet.)
- :class:`CollisionAvoidance`: answers free of self-collision only, on the allowed-collision
  matrix of ``samples`` configurations kept in ``cache_dir`` (None in :class:`IKOptions`: no
  avoidance).

:class:`IKOptions` holds the three. It is built once -- by the service's request schema, by a
command line, or from the use cases' keywords (:meth:`IKOptions.split`, so that
``ik(model, T, link="tool0", restarts=10)`` keeps working) -- and validated when built. A new
option is one field of one of these objects, one field of the request schema and one argument of
the command line.

>>> options, rest = IKOptions.split(None, {"restarts": 10, "limits": "ignore", "link": "tool0"})
>>> options.settings.restarts, options.settings.max_iterations, options.solutions.solution_limits, rest
(10, 100, 'ignore', {'link': 'tool0'})
>>> IKSettings(mode="orientation")
Traceback (most recent call last):
...
kinematics.errors.KinematicsError: mode: 'orientation' is not one of pose, position
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from ..algorithms import ik as _ik
from ..algorithms.collision_matrix import DEFAULT_SAMPLES
from ..algorithms.ik_redundant import Redundancy
from ..errors import KinematicsError

#: ``solutions``: a single answer, or every solution
SOLUTIONS = ("one", "all")
#: ``method``: the chain's closed form where it has one, the closed form or an error, the search only
METHODS = ("auto", "analytic", "numeric")
#: ``solution_limits`` (the keyword ``limits``): solutions inside the limits (2 pi copies), or each branch once
SOLUTION_LIMITS = ("respect", "ignore")


def _one_of(name: str, value: Any, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise KinematicsError(f"{name}: {value!r} is not one of {', '.join(allowed)}")


@dataclass(frozen=True, slots=True)
class IKSettings:
    """The solver's settings: ``mode`` (``pose``: position and orientation; ``position``: the
    position only), ``position_tolerance`` (m) and ``rotation_tolerance`` (rad) a solution meets,
    ``max_iterations`` (steps per attempt) and ``restarts`` (attempts from random configurations
    within the limits after the first) of the numerical solver, ``random_seed`` of its draws (the
    same inputs give the same answers)."""

    mode: str = "pose"
    position_tolerance: float = _ik.DEFAULT_POSITION_TOLERANCE
    rotation_tolerance: float = _ik.DEFAULT_ROTATION_TOLERANCE
    max_iterations: int = _ik.DEFAULT_MAX_ITERATIONS
    restarts: int = _ik.DEFAULT_RESTARTS
    random_seed: int = 0

    def __post_init__(self) -> None:
        _one_of("mode", self.mode, _ik.IK_MODES)
        for name, tol in (("tolerance.position", self.position_tolerance),
                          ("tolerance.rotation", self.rotation_tolerance)):
            if not (np.isfinite(tol) and tol >= _ik.MIN_TOLERANCE):
                raise KinematicsError(f"{name}: {tol!r}; give a finite tolerance of at least {_ik.MIN_TOLERANCE:g}")
        if self.max_iterations < 1 or self.restarts < 0:
            raise KinematicsError(f"max_iterations must be at least 1 and restarts at least 0 "
                                  f"(got {self.max_iterations}, {self.restarts})")

    def tolerances(self) -> dict[str, Any]:
        """What a solution must meet, as the algorithms' keywords (``mode`` and the two tolerances)."""
        return {"mode": self.mode, "position_tolerance": self.position_tolerance,
                "rotation_tolerance": self.rotation_tolerance}

    def solver(self, random_seed: int | None = None) -> dict[str, Any]:
        """The keywords of :func:`~kinematics.algorithms.ik.inverse_kinematics` (``random_seed``
        replaced, for a further round of draws)."""
        return {**self.tolerances(), "max_iterations": self.max_iterations, "restarts": self.restarts,
                "random_seed": self.random_seed if random_seed is None else random_seed}


#: the solver's defaults, written once (the service's schema and the command line read them here)
DEFAULT_SETTINGS = IKSettings()


@dataclass(frozen=True, slots=True)
class SolutionSet:
    """Which solutions are asked for: ``solutions`` (``one`` or ``all``), ``method`` (``auto``,
    ``analytic``, ``numeric``), ``locked`` joints ``{joint: value}`` (held, a read-only map, None
    without any), ``solution_limits`` (``respect`` or ``ignore``; see the module text) and
    ``redundancy`` (a redundant chain's :class:`~kinematics.algorithms.ik_redundant.Redundancy`, or its
    request map, read once here; None: none)."""

    solutions: str = "one"
    method: str = "auto"
    locked: Mapping[str, float] | None = None
    solution_limits: str = "respect"
    redundancy: Redundancy | None = None

    def __post_init__(self) -> None:
        _one_of("solutions", self.solutions, SOLUTIONS)
        _one_of("method", self.method, METHODS)
        _one_of("limits", self.solution_limits, SOLUTION_LIMITS)
        if self.locked is not None:  # a frozen object holds no dict
            object.__setattr__(self, "locked", MappingProxyType(dict(self.locked)))
        if self.redundancy is not None:
            object.__setattr__(self, "redundancy", Redundancy.of(self.redundancy))

    @property
    def locked_map(self) -> dict[str, float] | None:
        """``locked`` as a plain dict (None without locked joints)."""
        return None if self.locked is None else dict(self.locked)


@dataclass(frozen=True, slots=True)
class CollisionAvoidance:
    """Answers free of self-collision only: the enabled pairs of the model's allowed-collision
    matrix from ``samples`` random configurations, kept in ``cache_dir`` (None: not kept)."""

    samples: int = DEFAULT_SAMPLES
    cache_dir: Any = None

    def filter(self, model, user_pairs=None):
        """``free(Q)`` (R, dof) -> (R,) bool of ``model``, with the pairs a user allows and forbids
        (``Query.collision_pairs``)
        (:func:`~kinematics.usecases.collision.collision_filter`: a model without collision geometry
        is a :class:`~kinematics.errors.CollisionError` naming ``avoid_collisions``)."""
        from .collision import collision_filter

        return collision_filter(model, "avoid_collisions", samples=self.samples, cache_dir=self.cache_dir,
                                user_pairs=user_pairs)


#: the use cases' keywords of :class:`IKOptions`: keyword -> (the object, its field)
_KEYWORDS = {
    **{f.name: ("settings", f.name) for f in dataclasses.fields(IKSettings)},
    "solutions": ("solutions", "solutions"), "method": ("solutions", "method"), "locked": ("solutions", "locked"),
    "limits": ("solutions", "solution_limits"), "redundancy": ("solutions", "redundancy"),
    "collision_samples": ("collisions", "samples"), "cache_dir": ("collisions", "cache_dir"),
}


@dataclass(frozen=True, slots=True)
class IKOptions:
    """How to solve an IK request: :class:`IKSettings`, :class:`SolutionSet` and, to avoid
    self-collision, :class:`CollisionAvoidance` (None: collisions are not looked at)."""

    settings: IKSettings = field(default_factory=IKSettings)
    solutions: SolutionSet = field(default_factory=SolutionSet)
    collisions: CollisionAvoidance | None = None

    @classmethod
    def split(cls, options: IKOptions | None, keywords: dict[str, Any]) -> tuple[IKOptions, dict[str, Any]]:
        """``(options with the IK keywords of keywords applied, the other keywords)``: the library's
        keywords ``mode``, ``position_tolerance``, ``rotation_tolerance``, ``max_iterations``,
        ``restarts``, ``random_seed``, ``solutions``, ``method``, ``locked``, ``limits``,
        ``redundancy``, ``avoid_collisions``, ``collision_samples`` and ``cache_dir`` become fields of the objects;
        the rest (the query's fields) is returned as is."""
        options = options or DEFAULT_OPTIONS
        parts: dict[str, dict[str, Any]] = {"settings": {}, "solutions": {}, "collisions": {}}
        rest: dict[str, Any] = {}
        avoid = None
        for name, value in keywords.items():
            if name == "avoid_collisions":
                avoid = bool(value)
            elif name in _KEYWORDS:
                part, attr = _KEYWORDS[name]
                parts[part][attr] = value
            else:
                rest[name] = value
        if not any(parts.values()) and avoid is None:
            return options, rest
        collisions = options.collisions
        if avoid is False:
            collisions = None
        elif avoid or (collisions is not None and parts["collisions"]):
            collisions = dataclasses.replace(collisions or CollisionAvoidance(), **parts["collisions"])
        return cls(dataclasses.replace(options.settings, **parts["settings"]) if parts["settings"] else options.settings,
                   dataclasses.replace(options.solutions, **parts["solutions"]) if parts["solutions"]
                   else options.solutions, collisions), rest


#: the options of a call that gives none (frozen: one object serves every such call)
DEFAULT_OPTIONS = IKOptions()
