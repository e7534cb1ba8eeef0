"""The request shape every use case takes: :class:`Query`, "which frame of which model, how".

A :class:`Query` names the model, the link(s), a point or tool frame on them, the base pose,
the floating base, the policy for joint values out of their limits, whether to verify with
Pinocchio, the normalisation of quaternions and the caller's :class:`Budget`. It is built once
(from a service request by ``app.schemas.QueryRequest.to_query``, from a command line, or by
hand) and validated when built: the limits policy, the point or tool. Each use case then takes
``(query, its own arguments)``: :func:`~kinematics.usecases.fk.fk` ``(query, q)``,
:func:`~kinematics.usecases.velocity.velocity` ``(query, q, qdot)``,
:func:`~kinematics.usecases.ik.ik` ``(query, target)``, ... and does the shared steps through
the query's methods, written once here: the joint values (:meth:`Query.joints`), the link(s)
(:meth:`Query.link_names`, :meth:`Query.frame_link`), the size checks of verification and
of the answer (:meth:`Query.check_sizes`), the base poses (:meth:`Query.base_poses`) and, for
IK, the target poses and seeds (:meth:`Query.targets`, :meth:`Query.seeds`).

For convenience every use case also takes a model and the query's fields as keywords
(``fk(model, q, links=["tool0"])`` is ``fk(Query(model, links=["tool0"]), q)``): :meth:`Query.of`.

>>> from kinematics.io import default_catalogue
>>> query = Query(default_catalogue().get("ur5"), link="tool0", point=[0.0, 0.0, 0.1])
>>> query.frame_link(), query.T_tool[:3, 3]
('tool0', array([0. , 0. , 0.1]))
>>> Q, is_batch = query.joints([[0.0] * 6] * 2)
>>> Q.shape, is_batch
((2, 6), True)
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from ..engine.poe import compile_model
from ..errors import BudgetError, ConfigurationNormError, JointValueError, KinematicsError
from ..io.floating import with_floating_base
from ..io.poses import base_poses, pose_list, tool_offset
from ..model.joint_values import as_batch, limit_violations, out_of_limits, read_joint_values, require_within_limits
from ..model.robot import RobotModel

#: What to do with joint values outside their limits: compute and report them, or refuse.
LIMIT_POLICIES = ("report", "refuse")


@dataclass(frozen=True, slots=True)
class Budget:
    """Upper bounds a caller puts on one request (None: unbounded).

    ``max_batch``: configurations (IK: targets); ``max_verify``: configurations compared with
    Pinocchio; ``max_result_values``: numbers in the answer; ``max_ik_work``: IK steps a request
    may take at most (targets x (restarts + 1) x max_iterations); ``max_workspace_samples``:
    samples of a workspace; ``max_ik_solutions``: IK solutions one request may list (every
    solution of every target, or of every target of a Cartesian path, counted before the work by
    the most its chain can have); ``max_measurements``: measurements of one calibration. Over a
    bound: :class:`BudgetError` naming the setting.

    The pattern of every operation (:meth:`check`): say how large the work and the answer will be
    *before* doing the work, from the request alone (sizes, counts, the largest answer it could
    build), and refuse over a bound; a refused request allocates nothing. Then, during the work,
    check the cancellation token (:mod:`kinematics.engine.cancel`) in every loop that can run long.
    """

    max_batch: int | None = None
    max_verify: int | None = None
    max_result_values: int | None = None
    max_ik_work: int | None = None
    max_workspace_samples: int | None = None
    max_ik_solutions: int | None = None
    max_measurements: int | None = None

    def check(self, setting: str, n: int, *, what: str, field: str) -> None:
        """:class:`BudgetError` when ``n`` (how much of ``what`` a request would make or hold, counted
        before the work) is over the bound ``setting`` (the name of a field of this budget, None:
        unbounded); ``field`` names the request field to change. The error's ``budget`` is the
        setting's name without ``max_`` (``ik-solutions``), as the service's 413 type says.

        >>> Budget(max_ik_solutions=100).check("max_ik_solutions", 256, what="IK solutions", field="target")
        Traceback (most recent call last):
        ...
        kinematics.errors.BudgetError: the request could make 256 IK solutions; the limit (max_ik_solutions) is 100
        """
        limit = getattr(self, setting)
        if limit is not None and n > limit:
            raise BudgetError(f"the request could make {n} {what}; the limit ({setting}) is {limit}",
                              budget=setting.removeprefix("max_").replace("_", "-"), field=field, limit=limit)

    def check_workspace_samples(self, n: int) -> None:
        if self.max_workspace_samples is not None and n > self.max_workspace_samples:
            raise BudgetError(f"the workspace would take {n} samples; the limit (max_workspace_samples) is "
                              f"{self.max_workspace_samples}", budget="workspace-samples", field="samples",
                              limit=self.max_workspace_samples)

    def check_batch(self, n: int) -> None:
        if self.max_batch is not None and n > self.max_batch:
            raise BudgetError(f"q has {n} configurations; the limit is {self.max_batch}",
                              budget="batch", field="q", limit=self.max_batch)

    def check_verify(self, n: int) -> None:
        if self.max_verify is not None and n > self.max_verify:
            raise BudgetError(f"verify checks at most {self.max_verify} configurations, q has {n}",
                              budget="verify", field="verify", limit=self.max_verify)

    def check_result(self, values: int, what: str) -> None:
        if self.max_result_values is not None and values > self.max_result_values:
            raise BudgetError(f"the answer would hold {values} numbers ({what}); the limit is "
                              f"{self.max_result_values}: send fewer configurations or links",
                              budget="result", field="q", limit=self.max_result_values)

    def check_ik_work(self, targets: int, restarts: int, max_iterations: int) -> None:
        work = targets * (restarts + 1) * max_iterations
        if self.max_ik_work is not None and work > self.max_ik_work:
            raise BudgetError(f"IK may take {work} steps ({targets} targets x {restarts + 1} attempts x "
                              f"{max_iterations} iterations); the limit (max_ik_work) is {self.max_ik_work}: "
                              "send fewer targets, restarts or iterations", budget="ik-work", field="target",
                              limit=self.max_ik_work)


UNBOUNDED = Budget()


@dataclass(frozen=True, slots=True)
class Verification:
    """Largest deviations of an answer from Pinocchio (``reference`` names it and its version)."""

    reference: str
    max_position_error: float | None = None
    max_rotation_error: float | None = None
    max_jacobian_error: float | None = None
    max_velocity_error: float | None = None

    def as_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if getattr(self, f.name) is not None}


def model_for(model: RobotModel, floating_base: bool = False) -> RobotModel:
    """The model a request computes with: ``model``, or with ``floating_base`` the same robot on a
    free-flyer root joint ``root_joint`` (:func:`kinematics.io.floating.with_floating_base`, cached:
    ``q = (x, y, z, qx, qy, qz, qw, q...)``, Jacobians of 6 + n columns)."""
    return with_floating_base(model) if floating_base else model


@dataclass(frozen=True, slots=True, eq=False)
class Query:
    """Which frame of which model, how: the options every use case shares (validated when built).

    ``model``: the robot as registered; ``link`` (one frame: Jacobians, IK, workspaces, task
    vectors; None: the first leaf link) or ``links`` (FK and velocities: None, ``"all"`` or
    names); ``point`` ([x, y, z] in the link frame) or ``tool`` (a pose ``T_link_tool``): the
    frame at that offset from the link(s); ``base``: the root link's world pose ``T_world_root``
    (one, or one per configuration, any form :func:`~kinematics.io.poses.base_poses` reads);
    ``floating_base``: compute with the model on a free-flyer root joint (:func:`model_for`);
    ``normalize``: scale quaternions and planar ``(cos, sin)`` to unit norm instead of refusing
    them; ``limits``: ``report`` or ``refuse`` joint values outside their limits; ``verify``:
    compare with Pinocchio; ``budget``: the caller's :class:`Budget`; ``collision_pairs``: the
    link pairs a user allows and forbids in self-collision checks
    (:class:`~kinematics.algorithms.collision_matrix.UserPairs`, or its ``{"allow", "forbid"}``;
    None: the matrix as computed).

    Derived when built: ``robot``, the model computed with (``model`` or its floating-base form),
    and ``T_tool``, the (4, 4) ``T_link_tool`` of ``point`` / ``tool`` (None without either).
    """

    model: RobotModel
    link: str | None = None
    links: Sequence[str] | str | None = None
    point: Any = None
    tool: Any = None
    base: Any = None
    floating_base: bool = False
    normalize: bool = False
    limits: str = "report"
    verify: bool = False
    budget: Budget = UNBOUNDED
    collision_pairs: Any = None
    robot: RobotModel = field(init=False, repr=False)
    T_tool: np.ndarray | None = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.limits not in LIMIT_POLICIES:
            raise KinematicsError(f"limits: {self.limits!r} is not one of {', '.join(LIMIT_POLICIES)}")
        if self.links is not None and not isinstance(self.links, (str, tuple)):
            object.__setattr__(self, "links", tuple(self.links))  # a frozen query holds no list
        if isinstance(self.collision_pairs, dict):  # {"allow": [[a, b], ...], "forbid": [...]}
            from ..algorithms.collision_matrix import UserPairs
            object.__setattr__(self, "collision_pairs", UserPairs(**self.collision_pairs))
        object.__setattr__(self, "robot", model_for(self.model, self.floating_base))
        object.__setattr__(self, "T_tool", tool_offset(self.point, self.tool))

    @classmethod
    def of(cls, query: Query | RobotModel, **options: Any) -> Query:
        """``query`` itself (with ``options`` replaced, if any), or ``Query(model, **options)`` for a model."""
        if isinstance(query, Query):
            return dataclasses.replace(query, **options) if options else query
        return cls(query, **options)

    def replace(self, **options: Any) -> Query:
        """The same query with some fields changed (validated again)."""
        return dataclasses.replace(self, **options)

    # ------------------------------------------------------------------ the shared steps
    def joints(self, q: Any) -> tuple[np.ndarray, bool]:
        """``(Q (N, nq), is_batch)``: ``q`` read for :attr:`robot` (:func:`joint_batch`), within the budget's
        batch size; with ``limits="refuse"`` a value outside its limits raises :class:`LimitError`."""
        Q, is_batch = joint_batch(self.robot, q, self.budget, self.normalize)
        if self.limits == "refuse":
            require_within_limits(self.robot, Q)
        return Q, is_batch

    def targets(self, target: Any) -> tuple[np.ndarray, bool]:
        """``(T (N, 4, 4), is_batch)``: the target pose(s) ``T_world_link`` of an IK request, within the
        budget's batch size (and its verification size when :attr:`verify`)."""
        T, is_batch = pose_list(target, "target")
        self.budget.check_batch(T.shape[0])
        if self.verify:
            self.budget.check_verify(T.shape[0])
        return T, is_batch

    def seeds(self, seed: Any, n: int) -> np.ndarray | None:
        """The IK seeds ``S`` (1 or n, nq) for ``n`` targets read as joint values of :attr:`robot`
        (None without a seed); errors are prefixed ``seed:``."""
        if seed is None:
            return None
        try:
            S, _ = as_batch(self.robot, seed, self.normalize)
        except JointValueError as exc:
            raise prefixed(exc, "seed: ") from None
        if S.shape[0] not in (1, n):
            raise JointValueError(f"seed: {S.shape[0]} seeds for {n} targets (give one, or one per target)")
        return S

    def link_names(self, default: str = "leaves") -> list[str]:
        """The links of a multi-link answer: :attr:`links` resolved (:func:`resolve_links`); None gives
        the leaf links (``default="leaves"``) or every link (``default="all"``)."""
        if self.links is None and default == "all":
            return list(self.robot.links)
        return resolve_links(self.robot, self.links)

    def frame_link(self) -> str:
        """The one link of a single-frame answer: :attr:`link`, or the first leaf link (an unknown name
        raises :class:`~kinematics.errors.UnknownLinkError`)."""
        link = self.robot.leaf_links[0] if self.link is None else self.link
        compile_model(self.robot).link_indices([link])
        return link

    def check_sizes(self, n: int, values: int, what: str) -> None:
        """Within the budget: ``n`` configurations verified (when :attr:`verify`), ``values`` numbers
        in the answer (``what`` says how they add up)."""
        if self.verify:
            self.budget.check_verify(n)
        self.budget.check_result(values, what)

    def base_poses(self, n: int) -> np.ndarray | None:
        """``T_world_root`` (n, 4, 4) of :attr:`base` for ``n`` configurations, None without a base."""
        return base_poses(self.base, n)


def prefixed(exc: JointValueError, prefix: str) -> JointValueError:
    """The same error (class and joint) with ``prefix`` before its message."""
    if isinstance(exc, ConfigurationNormError):
        return ConfigurationNormError(f"{prefix}{exc}", joint=exc.joint)
    return JointValueError(f"{prefix}{exc}")


def joint_batch(model: RobotModel, q: Any, budget: Budget = UNBOUNDED,
                normalize: bool = False) -> tuple[np.ndarray, bool]:
    """``(Q (N, nq), is_batch)`` of joint values as a request gives them, within ``budget``
    (:func:`kinematics.model.joint_values.read_joint_values` reads every form: vectors, name
    maps, lists of those, a floating joint's pose object; quaternions and planar
    ``(cos, sin)`` must be of unit norm unless ``normalize``, then they are scaled)."""
    Q, is_batch = read_joint_values(model, q, normalize)
    budget.check_batch(Q.shape[0])
    return Q, is_batch


def resolve_links(model: RobotModel, links: Sequence[str] | str | None) -> list[str]:
    """The links an FK request names: None -> the leaf links; ``"all"`` -> every link; else the
    names, each once, in order (an unknown name raises :class:`UnknownLinkError`)."""
    if links is None:
        names = list(model.leaf_links)
    elif isinstance(links, str):
        if links != "all":
            raise KinematicsError(f"links: {links!r}; give 'all' or a list of link names")
        names = list(model.links)
    else:
        names = list(dict.fromkeys(links))
    compile_model(model).link_indices(names)
    return names


@dataclass(frozen=True, eq=False)
class Answer:
    """What every answer over joint values carries: the model computed with, the validated q and
    whether the request gave a batch."""

    model: RobotModel
    Q: np.ndarray  # (N, nq), the validated joint values (nq = dof for models of one-dof joints)
    is_batch: bool  # the request gave a list of configurations (not one vector or map)

    def out_of_limits(self) -> list[list[str]]:
        """Per configuration, the joints outside their limits."""
        return out_of_limits(self.model, self.Q)

    def out_of_limits_count(self) -> int:
        """How many configurations have a joint outside its limits."""
        return int(np.count_nonzero(limit_violations(self.model, self.Q).any(axis=1)))
