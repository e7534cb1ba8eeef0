"""The use cases: what the service's routes and the command line ask of the library.

"FK of these links for this q batch with this base, verified or not" is one call,
:func:`fk`; the Jacobian is :func:`jacobian`. Each validates the joint values (a vector, a
name map, or a list of those), applies the caller's :class:`Budget`, computes with the
compiled kernels, re-expresses the result in the world of the base pose, and on request
compares it with Pinocchio. The answers are plain objects of numpy arrays; turning them
into JSON or ``.npy`` is the caller's business.

Long calls (large FK / Jacobian / velocity batches, IK, workspaces) stop early inside a
``with cancellable(Cancellation(timeout=..., setting=...)):`` block when the token is cancelled
(:class:`~kinematics.errors.CancelledError`) or its time budget runs out
(:class:`~kinematics.errors.TimeBudgetError`); see :mod:`kinematics.engine.cancel`.

>>> from kinematics.io import default_catalogue
>>> ur5 = default_catalogue().get("ur5")
>>> answer = fk(ur5, [0.0] * 6, links=["tool0"])
>>> answer.poses.shape, answer.is_batch, answer.out_of_limits()
((1, 1, 4, 4), False, [[]])
>>> answer.poses[0, 0, :3, 3].round(6)
array([ 0.81725 ,  0.19145 , -0.005491])
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from .algorithms.base import jacobian_in_world, poses_in_world
from .algorithms.dh import urdf_to_dh
from .algorithms.fk import forward_kinematics
from .algorithms.ik import IKSolution, inverse_kinematics, pose_errors
from .algorithms import ik as _ik
from .algorithms import ik_all as _ik_all_mod
from .algorithms import ik_path as _ik_path
from .algorithms.ik_families import detect as _detect_family, reduce_chain as _reduce_chain
from .algorithms.jacobian import jacobian as _jacobian
from .algorithms.measures import conditioning
from .algorithms.velocity import twists_in_world, velocities as _velocities
from .algorithms import workspace as _workspace
from .engine.poe import compile_model, require_one_dof
from .engine.cancel import Cancellation, cancellable  # noqa: F401 - time budgets and cancellation of the calls below
from .errors import BudgetError, ConfigurationNormError, JointValueError, KinematicsError
from .io.catalogue import default_catalogue
from .io.dh_table import load_table, model_from_table
from .io.floating import with_floating_base
from .io.poses import base_poses, floating_joint_values, pose_list, tool_offset
from .io.urdf import load_urdf, parse_urdf
from .model.joint_values import (as_batch, as_velocity_batch, limit_violations, out_of_limits,
                                 require_within_limits)
from .model.robot import RobotModel
from .spatial.reference import Reference
from .spatial.transforms import inverse_transform, pose_components

#: What to do with joint values outside their limits: compute and report them, or refuse.
LIMIT_POLICIES = ("report", "refuse")


@dataclass(frozen=True)
class Budget:
    """Upper bounds a caller puts on one request (None: unbounded).

    ``max_batch``: configurations (IK: targets); ``max_verify``: configurations compared with
    Pinocchio; ``max_result_values``: numbers in the answer; ``max_ik_work``: IK steps a request
    may take at most (targets x (restarts + 1) x max_iterations). Over a bound: :class:`BudgetError`.
    """

    max_batch: int | None = None
    max_verify: int | None = None
    max_result_values: int | None = None
    max_ik_work: int | None = None
    max_workspace_samples: int | None = None

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


@dataclass(frozen=True)
class Verification:
    """Largest deviations of an answer from Pinocchio (``reference`` names it and its version)."""

    reference: str
    max_position_error: float | None = None
    max_rotation_error: float | None = None
    max_jacobian_error: float | None = None
    max_velocity_error: float | None = None

    def as_dict(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if v is not None}


def model_for(model: RobotModel, floating_base: bool = False) -> RobotModel:
    """The model a request computes with: ``model``, or with ``floating_base`` the same robot on a
    free-flyer root joint ``root_joint`` (:func:`kinematics.io.floating.with_floating_base`, cached:
    ``q = (x, y, z, qx, qy, qz, qw, q...)``, Jacobians of 6 + n columns)."""
    return with_floating_base(model) if floating_base else model


@dataclass(frozen=True, eq=False)
class _Answer:
    model: RobotModel
    Q: np.ndarray  # (N, nq), the validated joint values (nq = dof for models of one-dof joints)
    is_batch: bool  # the request gave a list of configurations (not one vector or map)

    def out_of_limits(self) -> list[list[str]]:
        """Per configuration, the joints outside their limits."""
        return out_of_limits(self.model, self.Q)

    def out_of_limits_count(self) -> int:
        """How many configurations have a joint outside its limits."""
        return int(np.count_nonzero(limit_violations(self.model, self.Q).any(axis=1)))


@dataclass(frozen=True, eq=False)
class FKAnswer(_Answer):
    links: list[str]
    poses: np.ndarray  # (N, L, 4, 4) T_world_link
    verification: Verification | None = None

    def components(self) -> dict[str, np.ndarray]:
        """``position`` (N, L, 3), ``quaternion`` (N, L, 4, w first) and ``rpy`` (N, L, 3) of the poses."""
        return pose_components(self.poses)


@dataclass(frozen=True, eq=False)
class JacobianAnswer(_Answer):
    link: str
    reference: Reference
    jacobians: np.ndarray  # (N, 6, dof), linear rows first
    verification: Verification | None = None

    def conditioning(self) -> dict[str, np.ndarray]:
        """Singular values, manipulability and condition number of each Jacobian."""
        return conditioning(self.jacobians)


def _pose_values(model: RobotModel, q: Any) -> Any:
    """Name maps with a floating joint given as a pose object (``{"position", "quaternion"}``,
    ``{"xyz", "rpy"}`` or a 4x4 matrix) -> the same maps with its 7 values (other forms unchanged)."""
    if not model.multi_dof:
        return q
    floating = [s.name for s in model.layout if s.type == "floating"]
    if isinstance(q, dict):
        return floating_joint_values(q, floating)
    if isinstance(q, list) and q and any(isinstance(x, dict) for x in q):
        return [floating_joint_values(x, floating, f"configuration {i}: ") if isinstance(x, dict) else x
                for i, x in enumerate(q)]
    return q


def _prefixed(exc: JointValueError, prefix: str) -> JointValueError:
    """The same error (class and joint) with ``prefix`` before its message."""
    if isinstance(exc, ConfigurationNormError):
        return ConfigurationNormError(f"{prefix}{exc}", joint=exc.joint)
    return JointValueError(f"{prefix}{exc}")


def joint_batch(model: RobotModel, q: Any, budget: Budget = UNBOUNDED,
                normalize: bool = False) -> tuple[np.ndarray, bool]:
    """``(Q (N, nq), is_batch)`` of joint values as a request gives them, within ``budget``.

    A list of equal-length number lists becomes one array at once (the common batch), so
    a large batch is not validated number by number; anything else (name maps, ragged
    lists) goes through :func:`~kinematics.model.as_batch`, which names what is wrong.
    A floating joint's value in a name map may be a pose object; quaternions and planar
    ``(cos, sin)`` must be of unit norm unless ``normalize`` (then they are scaled).
    """
    q = _pose_values(model, q)
    if isinstance(q, list) and q and isinstance(q[0], list):
        try:
            arr = np.array(q, dtype=float)
        except (TypeError, ValueError):  # ragged or not numbers: let as_batch name the configuration
            arr = None
        if arr is not None and arr.ndim == 2:
            q = arr
    Q, is_batch = as_batch(model, q, normalize)
    budget.check_batch(Q.shape[0])
    if Q.shape[0] == 0:
        raise JointValueError("q has no configuration")
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


def _prepare(model: RobotModel, q: Any, limits: str, budget: Budget,
             normalize: bool = False) -> tuple[np.ndarray, bool]:
    if limits not in LIMIT_POLICIES:
        raise KinematicsError(f"limits: {limits!r} is not one of {', '.join(LIMIT_POLICIES)}")
    Q, is_batch = joint_batch(model, q, budget, normalize)
    if limits == "refuse":
        require_within_limits(model, Q)
    return Q, is_batch


def fk(model: RobotModel, q: Any, *, links: Sequence[str] | str | None = None, base: Any = None,
       point: Any = None, tool: Any = None, verify: bool = False, limits: str = "report",
       budget: Budget = UNBOUNDED, floating_base: bool = False, normalize: bool = False) -> FKAnswer:
    """Poses ``T_world_link`` of ``links`` (None: the leaf links; ``"all"``; or names) for joint
    values ``q``; ``base`` is the root link's world pose (one, or one per configuration, in
    any form :func:`~kinematics.io.poses.base_poses` reads). ``point`` ([x, y, z] in the link
    frame) or ``tool`` (a pose ``T_link_tool`` in any form) make the poses those of that frame,
    ``T_world_link @ T_link_tool``, on every link returned. ``verify`` compares the poses
    (in the root frame) with Pinocchio's; ``limits="refuse"`` raises :class:`LimitError`.
    ``floating_base``: compute with the model on a free-flyer root joint (:func:`model_for`);
    ``normalize``: scale quaternions and planar ``(cos, sin)`` to unit norm instead of refusing them."""
    model = model_for(model, floating_base)
    Q, is_batch = _prepare(model, q, limits, budget, normalize)
    names = resolve_links(model, links)
    N = Q.shape[0]
    if verify:
        budget.check_verify(N)
    budget.check_result(N * len(names) * 16, f"{N} configurations x {len(names)} links x 16")
    B = base_poses(base, N)
    T_tool = tool_offset(point, tool)
    T = forward_kinematics(model, Q, names, tool=T_tool)
    verification = None
    if verify:
        from .verify.pinocchio import compare_fk

        dev = compare_fk(model, Q, names, poses=T, tool=T_tool)
        verification = Verification(dev.reference, max_position_error=dev.max_position_error,
                                    max_rotation_error=dev.max_rotation_error)
    return FKAnswer(model, Q, is_batch, names, poses_in_world(T, B), verification)


def jacobian(model: RobotModel, q: Any, *, link: str | None = None, reference: str = Reference.WORLD,
             base: Any = None, point: Any = None, tool: Any = None, verify: bool = False, limits: str = "report",
             budget: Budget = UNBOUNDED, floating_base: bool = False, normalize: bool = False) -> JacobianAnswer:
    """Jacobians (N, 6, dof) of ``link`` (None: the first leaf link) in ``reference``, for joint
    values ``q``, re-expressed in the world of ``base``; ``point`` / ``tool``: the Jacobian of the
    frame at that offset from the link (Pinocchio's frame semantics, see
    :func:`kinematics.algorithms.jacobian.jacobian`); ``verify``, ``limits``, ``floating_base`` and
    ``normalize`` as :func:`fk`. The columns follow the velocity vector (``nv``: 6 per floating
    joint, 3 per planar joint)."""
    model = model_for(model, floating_base)
    Q, is_batch = _prepare(model, q, limits, budget, normalize)
    link = model.leaf_links[0] if link is None else link
    compile_model(model).link_indices([link])
    N = Q.shape[0]
    if verify:
        budget.check_verify(N)
    budget.check_result(N * 6 * model.dof, f"{N} configurations x 6 x {model.dof}")
    B = base_poses(base, N)
    T_tool = tool_offset(point, tool)
    J = _jacobian(model, Q, link, reference, tool=T_tool)
    verification = None
    if verify:
        from .verify.pinocchio import REFERENCE_NAME, compare_jacobian

        err = compare_jacobian(model, Q, link, references=(reference,), jacobians={reference: J}, tool=T_tool)
        verification = Verification(REFERENCE_NAME, max_jacobian_error=err)
    return JacobianAnswer(model, Q, is_batch, link, Reference(reference), jacobian_in_world(J, B, reference),
                          verification)


@dataclass(frozen=True, eq=False)
class VelocityAnswer(_Answer):
    """Velocities of ``links`` for N configurations: ``twists[reference]`` (N, L, 6), linear part
    first; ``Qd`` (N, dof) the validated joint velocities."""

    Qd: np.ndarray
    links: list[str]
    twists: dict[Reference, np.ndarray]
    verification: Verification | None = None

    @property
    def linear(self) -> np.ndarray:
        """(N, L, 3) velocity of each link origin (or tool frame origin), world axes."""
        return self.twists[Reference.LOCAL_WORLD_ALIGNED][..., :3]

    @property
    def angular(self) -> np.ndarray:
        """(N, L, 3) angular velocity of each link, world axes."""
        return self.twists[Reference.LOCAL_WORLD_ALIGNED][..., 3:]


def velocity(model: RobotModel, q: Any, qdot: Any, *, links: Sequence[str] | str | None = None, base: Any = None,
             point: Any = None, tool: Any = None, verify: bool = False, limits: str = "report",
             budget: Budget = UNBOUNDED, floating_base: bool = False, normalize: bool = False) -> VelocityAnswer:
    """Velocities of ``links`` (None or ``"all"``: every link; or names) for joint values ``q`` and
    joint velocities ``qdot`` (the same forms, one velocity vector per configuration), computed
    in one pass down the tree (:mod:`kinematics.algorithms.velocity`): per link the velocity of
    its origin and the angular velocity in world axes, and the twist in the three references.

    ``base``: the root link's world pose (at rest), as :func:`fk`. ``point`` / ``tool``: the
    velocity of the frame at that offset from each link (as Pinocchio has it for a frame added
    there). ``verify`` compares every twist with Pinocchio's ``getFrameVelocity``.
    ``floating_base``, ``normalize`` as :func:`fk`; ``qdot`` has ``nv`` entries (a floating joint's
    6 are its twist in its own frame, linear first; a planar joint's 3 are ``vx, vy, ωz``).
    """
    model = model_for(model, floating_base)
    Q, is_batch = _prepare(model, q, limits, budget, normalize)
    try:
        if model.multi_dof:
            Qd, qd_batch = as_velocity_batch(model, qdot)
            budget.check_batch(Qd.shape[0])
        else:
            Qd, qd_batch = joint_batch(model, qdot, budget)
    except JointValueError as exc:
        raise _prefixed(exc, "qdot: ") from None
    N = Q.shape[0]
    if Qd.shape[0] != N or qd_batch != is_batch:
        raise JointValueError(f"qdot: {Qd.shape[0]} velocity vector(s) for {N} configuration(s) of q: give one per "
                              "configuration, in the same form (a vector or a list of vectors)")
    names = list(model.links) if links is None else resolve_links(model, links)
    if verify:
        budget.check_verify(N)
    budget.check_result(N * len(names) * 18, f"{N} configurations x {len(names)} links x 3 twists x 6")
    B = base_poses(base, N)
    T_tool = tool_offset(point, tool)
    V = _velocities(model, Q, Qd, names, tool=T_tool)
    verification = None
    if verify:
        from .verify.pinocchio import REFERENCE_NAME, compare_velocity

        err = compare_velocity(model, Q, Qd, names, twists=V, tool=T_tool)
        verification = Verification(REFERENCE_NAME, max_velocity_error=err)
    if B is not None:
        V = {ref: twists_in_world(v, B, ref) for ref, v in V.items()}
    return VelocityAnswer(model, Q, is_batch, Qd, names, V, verification)


@dataclass(frozen=True, eq=False)
class IKAnswer:
    """IK answers for N targets (``is_batch``: the request gave a list of targets)."""

    model: RobotModel
    link: str
    mode: str
    is_batch: bool
    targets: np.ndarray  # (N, 4, 4) T_world_link
    solution: IKSolution
    verification: dict[str, Any] | None = None  # Pinocchio's FK of every answer against its target


def ik(model: RobotModel, target: Any, *, link: str | None = None, seed: Any = None, mode: str = "pose",
       position_tolerance: float = _ik.DEFAULT_POSITION_TOLERANCE,
       rotation_tolerance: float = _ik.DEFAULT_ROTATION_TOLERANCE,
       max_iterations: int = _ik.DEFAULT_MAX_ITERATIONS, restarts: int = _ik.DEFAULT_RESTARTS,
       random_seed: int = 0, base: Any = None, point: Any = None, tool: Any = None, verify: bool = False,
       budget: Budget = UNBOUNDED, floating_base: bool = False, normalize: bool = False,
       solutions: str = "one", method: str = "auto", locked: dict | None = None,
       limits: str = "respect") -> "IKAnswer | IKAllAnswer":
    """Joint values putting ``link`` (None: the first leaf link) at ``target``: one pose or a list
    (any form :func:`~kinematics.io.poses.pose_list` reads, or an (N, 4, 4) array), ``T_world_link``.
    With ``point`` ([x, y, z] in the link frame) or ``tool`` (a pose ``T_link_tool``) the targets
    are poses of that frame, ``T_world_link @ T_link_tool`` (a TCP without editing the URDF).

    ``seed``: one q (vector or name map) for every target, or one per target; default the middle
    of the limits. ``base`` as for :func:`fk`. ``success`` holds only where the answer's FK is
    within the tolerances and the answer inside the limits (:mod:`kinematics.algorithms.ik`).
    ``verify``: Pinocchio's FK of every answer, against its target. ``floating_base``: solve with
    the model on a free-flyer root joint (the answer has ``7 + n`` values); ``normalize``: of the seeds.
    Models with floating or planar joints are solved on the configuration manifold
    (:func:`kinematics.algorithms.ik.tree_inverse_kinematics`).

    ``solutions="all"`` answers **every** solution (:class:`IKAllAnswer`,
    :mod:`kinematics.algorithms.ik_all`): ``method`` ``"auto"`` (the closed form of the chain's
    family where it has one, the multistart search otherwise), ``"analytic"`` (the closed form, or
    an error) or ``"numeric"`` (the search); ``locked`` ``{joint: value}`` holds joints (a 7-dof arm
    with one locked is a 6-joint chain); ``limits`` ``"respect"`` (every solution inside the limits,
    ``q + 2πk`` copies included) or ``"ignore"`` (each branch once, revolute angles in (−π, π]).
    ``solutions="one"`` with ``method="analytic"`` or ``locked``: the solution nearest the seed
    (default: the middle of the limits) among all of them, else today's numerical answer.
    """
    if solutions not in ("one", "all"):
        raise KinematicsError(f"solutions: {solutions!r} is not one of one, all")
    if solutions == "all" or method == "analytic" or locked:
        return _ik_all(model, target, link=link, seed=seed, mode=mode, position_tolerance=position_tolerance,
                       rotation_tolerance=rotation_tolerance, base=base, point=point, tool=tool, verify=verify,
                       budget=budget, normalize=normalize, method=method, locked=locked, limits=limits,
                       one=solutions == "one", max_iterations=max_iterations, restarts=restarts,
                       random_seed=random_seed, floating_base=floating_base)
    if method not in _ik_all_mod.METHODS:
        raise KinematicsError(f"method: {method!r} is not one of {', '.join(_ik_all_mod.METHODS)}")
    model = model_for(model, floating_base)
    T, is_batch = pose_list(target, "target")
    N = T.shape[0]
    budget.check_batch(N)
    if verify:
        budget.check_verify(N)
    budget.check_ik_work(N, restarts, max_iterations)
    link = model.leaf_links[0] if link is None else link
    compile_model(model).link_indices([link])
    seeds = None
    if seed is not None:
        try:
            S, _ = as_batch(model, _pose_values(model, seed), normalize)
        except JointValueError as exc:
            raise _prefixed(exc, "seed: ") from None
        if S.shape[0] not in (1, N):
            raise JointValueError(f"seed: {S.shape[0]} seeds for {N} targets (give one, or one per target)")
        seeds = S
    B = base_poses(base, N)
    B = None if B is None else np.ascontiguousarray(B)
    T_tool = tool_offset(point, tool)
    solution = inverse_kinematics(model, link, T, seeds, base=B, mode=mode, position_tolerance=position_tolerance,
                                  rotation_tolerance=rotation_tolerance, max_iterations=max_iterations,
                                  restarts=restarts, random_seed=random_seed, tool=T_tool)
    verification = None
    if verify:
        from .verify.pinocchio import REFERENCE_NAME, reference_for

        frames = reference_for(model).frames([link], T_tool)
        theirs = np.array([frames.poses(q)[link] for q in solution.q]).reshape(N, 4, 4)
        T_root = T if B is None else np.matmul(inverse_transform(B), T)
        position, rotation = pose_errors(theirs, T_root)
        verification = {"reference": REFERENCE_NAME, "position_error": position, "rotation_error": rotation}
    return IKAnswer(model, link, mode, is_batch, T, solution, verification)


@dataclass(frozen=True, eq=False)
class IKAllAnswer:
    """Every IK solution of N targets (``is_batch``: the request gave a list).

    ``q`` (N, K, dof) padded with NaN, ``count`` (N,), ``within_limits``, ``singular`` (N, K) bool,
    ``position_error``, ``rotation_error`` (N, K), ``complete`` (N,): see
    :class:`~kinematics.algorithms.ik_all.AllSolutions`; ``family`` (its name), ``method``
    (``"analytic"`` or ``"search"``); ``verification``: Pinocchio's FK of every listed solution
    (``max_position_error``, ``max_rotation_error`` against its target).
    """

    model: RobotModel
    link: str
    mode: str
    is_batch: bool
    targets: np.ndarray
    family: str
    method: str
    q: np.ndarray
    count: np.ndarray
    within_limits: np.ndarray
    singular: np.ndarray
    position_error: np.ndarray
    rotation_error: np.ndarray
    complete: np.ndarray
    locked: dict
    verification: dict[str, Any] | None = None

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self.model.joint_names

    def solutions(self, n: int = 0) -> list[dict[str, Any]]:
        """The solutions of target ``n`` as records ``{q, position_error, rotation_error, within_limits, singular}``."""
        return [{"q": self.q[n, k].tolist(), "position_error": float(self.position_error[n, k]),
                 "rotation_error": float(self.rotation_error[n, k]), "within_limits": bool(self.within_limits[n, k]),
                 "singular": bool(self.singular[n, k])} for k in range(int(self.count[n]))]


def _ik_all(model: RobotModel, target: Any, *, link, seed, mode, position_tolerance, rotation_tolerance, base, point,
            tool, verify, budget, normalize, method, locked, limits, one, max_iterations, restarts, random_seed,
            floating_base):
    if floating_base:
        raise KinematicsError("floating_base: every IK solution needs a fixed base (give the base pose as base)")
    T, is_batch = pose_list(target, "target")
    N = T.shape[0]
    budget.check_batch(N)
    if verify:
        budget.check_verify(N)
    link = model.leaf_links[0] if link is None else link
    compile_model(model).link_indices([link])
    # the work: candidates x Newton steps per target (the search: its seeds x its steps)
    closed = _detect_family(_reduce_chain(model, link, locked)).closed_form and method != "numeric"
    if closed:
        budget.check_ik_work(N, 15, _ik_all_mod.NEAR_STEPS)
    else:
        budget.check_ik_work(N, _ik_all_mod.SEARCH_SEEDS - 1, _ik_all_mod.SEARCH_STEPS)
    seeds = None
    if seed is not None:
        try:
            S, _ = as_batch(model, _pose_values(model, seed), normalize)
        except JointValueError as exc:
            raise _prefixed(exc, "seed: ") from None
        if S.shape[0] not in (1, N):
            raise JointValueError(f"seed: {S.shape[0]} seeds for {N} targets (give one, or one per target)")
        seeds = S
    elif one:
        seeds = _ik.middle_of_limits(model)[None]
    B = base_poses(base, N)
    T_tool = tool_offset(point, tool)
    sol = _ik_all_mod.all_solutions(model, link, T, base=B, tool=T_tool, locked=locked, limits=limits, method=method,
                                    seed=seeds, mode=mode, position_tolerance=position_tolerance,
                                    rotation_tolerance=rotation_tolerance)
    if one:  # the solution nearest the seed, or today's numerical answer where there is none
        q = np.where(sol.count[:, None] > 0, np.nan_to_num(sol.q[:, 0]) if sol.q.shape[1] else 0.0, np.nan)
        missing = np.flatnonzero(sol.count == 0)
        position = np.where(sol.count > 0, sol.position_error[:, 0] if sol.q.shape[1] else 0.0, np.nan)
        rotation = np.where(sol.count > 0, sol.rotation_error[:, 0] if sol.q.shape[1] else 0.0, np.nan)
        success = sol.count > 0
        iterations = np.zeros(N, dtype=np.int64)
        if missing.size:
            fallback = inverse_kinematics(model, link, T[missing], None if seeds is None else seeds[missing % len(seeds)],
                                          base=None if B is None else np.broadcast_to(B, (N, 4, 4))[missing], mode=mode,
                                          position_tolerance=position_tolerance, rotation_tolerance=rotation_tolerance,
                                          max_iterations=max_iterations, restarts=restarts, random_seed=random_seed,
                                          tool=T_tool)
            q[missing], position[missing], rotation[missing] = fallback.q, fallback.position_error, fallback.rotation_error
            iterations[missing] = fallback.iterations
            success[missing] = False  # an answer with a locked joint or the closed form's: none exists
        return IKAnswer(model, link, mode, is_batch, T, IKSolution(q, success, position, rotation, iterations))
    verification = None
    if verify:
        from .verify.pinocchio import REFERENCE_NAME, reference_for

        frames = reference_for(model).frames([link], T_tool)
        T_root = T if B is None else np.matmul(inverse_transform(B), T)
        worst_p = worst_r = 0.0
        for n in range(N):
            for k in range(int(sol.count[n])):
                theirs = frames.poses(sol.q[n, k])[link][None]
                p, r = pose_errors(theirs, T_root[n:n + 1])
                worst_p, worst_r = max(worst_p, float(p[0])), max(worst_r, float(r[0]))
        verification = {"reference": REFERENCE_NAME, "max_position_error": worst_p, "max_rotation_error": worst_r}
    return IKAllAnswer(model, link, mode, is_batch, T, sol.family.name, sol.method, sol.q, sol.count, sol.within_limits,
                       sol.singular, sol.position_error, sol.rotation_error, sol.complete,
                       dict(sol.family.chain.locked), verification)


def ik_family(model: RobotModel, *, link: str | None = None, locked: dict | None = None) -> dict[str, Any]:
    """The family of the chain to ``link`` with ``locked`` joints held: ``{link, joints, locked, family,
    closed_form, max_solutions, subproblems, near}`` (:mod:`kinematics.algorithms.ik_families`)."""
    link = model.leaf_links[0] if link is None else link
    compile_model(model).link_indices([link])
    chain = _reduce_chain(model, link, locked)
    fam = _detect_family(chain)
    return {"link": link, "joints": list(chain.joints), "locked": dict(chain.locked), **fam.as_dict()}


def ik_path(model: RobotModel, waypoints: Any, *, link: str | None = None, seed: Any = None, step: dict | None = None,
            max_joint_step: float = _ik_path.DEFAULT_MAX_JOINT_STEP,
            position_tolerance: float = _ik.DEFAULT_POSITION_TOLERANCE,
            rotation_tolerance: float = _ik.DEFAULT_ROTATION_TOLERANCE, locked: dict | None = None, base: Any = None,
            point: Any = None, tool: Any = None, normalize: bool = False) -> "_ik_path.PathAnswer":
    """A Cartesian path of ``link`` through ``waypoints`` (two or more poses, world frame) from ``seed``
    (the start configuration): :func:`kinematics.algorithms.ik_path.cartesian_path`. ``step``:
    ``{"position": m, "rotation": rad}``, the largest step between consecutive targets."""
    W, _ = pose_list(waypoints, "waypoints")
    link = model.leaf_links[0] if link is None else link
    compile_model(model).link_indices([link])
    q0 = None
    if seed is not None:
        try:
            S, _ = as_batch(model, _pose_values(model, seed), normalize)
        except JointValueError as exc:
            raise _prefixed(exc, "seed: ") from None
        if S.shape[0] != 1:
            raise JointValueError("seed: give one start configuration")
        q0 = S[0]
    step = step or {}
    B = base_poses(base, 1)
    return _ik_path.cartesian_path(model, link, W, q0, base=None if B is None else B.reshape(-1, 4, 4)[0],
                                   tool=tool_offset(point, tool), locked=locked,
                                   step_position=float(step.get("position", _ik_path.DEFAULT_STEP_POSITION)),
                                   step_rotation=float(step.get("rotation", _ik_path.DEFAULT_STEP_ROTATION)),
                                   max_joint_step=max_joint_step, position_tolerance=position_tolerance,
                                   rotation_tolerance=rotation_tolerance)


def workspace(model: RobotModel, link: str | None = None, *, samples: int = _workspace.DEFAULT_SAMPLES,
              point: Any = None, tool: Any = None, voxel: float | None = None, measure: str = "pose",
              random_seed: int = 0, budget: Budget = UNBOUNDED, progress=None) -> _workspace.Workspace:
    """The sampled workspace of ``link`` (None: the first leaf link), or of the frame ``point`` /
    ``tool`` on it: ``samples`` configurations drawn uniformly within the limits (seeded by
    ``random_seed``), their positions and manipulability (``measure``: ``pose``, the 6 x k
    Jacobian, or ``position``, its 3 rows), the bounding box, reach, an occupancy-grid volume
    (area for a planar arm) with its convergence and the dexterity map on cells of edge
    ``voxel`` (None: chosen from the samples); see :mod:`kinematics.algorithms.workspace`.
    ``samples`` is bounded by ``budget.max_workspace_samples``; ``progress(n)`` is called after
    each chunk of n samples."""
    link = model.leaf_links[0] if link is None else link
    require_one_dof(model, "the workspace").link_indices([link])
    samples = int(samples)
    if samples < 1:
        raise KinematicsError(f"samples: {samples}; give at least 1")
    budget.check_workspace_samples(samples)
    return _workspace.workspace(model, link, samples, tool=tool_offset(point, tool), measure=measure, voxel=voxel,
                                random_seed=random_seed, progress=progress)


def load_model(*, model_id: str | None = None, urdf: str | None = None, dh: str | None = None,
               xacro: str | None = None, mjcf: str | None = None, args: dict[str, Any] | None = None,
               package_paths: Sequence[str] = ()) -> RobotModel:
    """The model of a catalogue id, a URDF file, a DH table file, a xacro file or an MJCF file
    (exactly one of them). A xacro file is expanded in a sandboxed process that may read only
    its directory and ``package_paths`` (whose packages ``$(find pkg)`` resolves), with the
    xacro ``args``; meshes are never opened."""
    if sum(x is not None for x in (model_id, urdf, dh, xacro, mjcf)) != 1:
        raise KinematicsError("name exactly one model: a catalogue id, a URDF, DH table, xacro or MJCF file")
    if (args or package_paths) and xacro is None:
        raise KinematicsError("xacro arguments and package paths apply to a xacro file (--xacro) only")
    if model_id is not None:
        return default_catalogue().get(model_id)
    if urdf is not None:
        return load_urdf(urdf)
    if xacro is not None:
        from .io.xacro import load_xacro

        return load_xacro(xacro, args=args, package_paths=package_paths)
    if mjcf is not None:
        from .io.mjcf import load_mjcf

        return load_mjcf(mjcf)
    return model_from_table(load_table(dh))


#: A one-joint robot for :func:`warm_up`.
_WARM_UP_URDF = """<robot name="warm_up">
  <link name="base"/><link name="arm"/>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>"""


def warm_up() -> None:
    """Import the URDF parser stack and load the compiled kernels now (FK, Jacobian, velocity, workspace, IK, rotation
    to quaternion, FK and Jacobians below a floating base; compiled on the first run on a machine, a few seconds, then read from
    numba's disk cache), so that a server's first request pays for neither."""
    model = parse_urdf(_WARM_UP_URDF)
    pose = fk(model, [0.5]).poses[0, 0]
    fk(model, [0.0]).components()
    jacobian(model, [0.0], link="arm")
    velocity(model, [0.0], [0.0])
    workspace(model, "arm", samples=8)
    ik(model, pose, link="arm")
    # a floating base: the kernels below a floating root joint (engine/rooted.py)
    fk(model, model_for(model, floating_base=True).neutral, floating_base=True)
    jacobian(model, model_for(model, floating_base=True).neutral, link="arm", floating_base=True)


def compiled_models() -> tuple[int, int]:
    """``(compiled, cached)``: how many models this process has compiled to their PoE form so far,
    and how many compiled forms it holds now (one per live model). For monitoring."""
    from .engine.poe import _compiled

    return _compiled.built, len(_compiled)


def screws(model: RobotModel):
    """The model's product-of-exponentials parameters (:class:`~kinematics.engine.poe.PoEModel`):
    space screws ``S`` (angular first), axes ``w``, points ``r``, home poses ``M`` (models of
    one-dof joints only: :class:`~kinematics.errors.UnsupportedJointError` otherwise)."""
    return require_one_dof(model, "the product-of-exponentials form (screws)")


def dh_form(model: RobotModel, tip: str | None = None, convention: str = "standard"):
    """The DH table (:class:`~kinematics.io.dh_table.DHTable`) of the chain from the root to
    ``tip``, with base and tool; :class:`NoDHFormError` when the chain has none."""
    require_one_dof(model, "a DH form")
    return urdf_to_dh(model, tip=tip, convention=convention)


def reference_name() -> str:
    """The reference library requests are verified against, with its version (``pinocchio 4.1.0``)."""
    from .verify.pinocchio import REFERENCE_NAME

    return REFERENCE_NAME


# ---------------------------------------------------------------------- closed forms, task vectors, PoE and axes
#: what a symbolic request may ask for, and its formats (kinematics.algorithms.symbolic)
SYMBOLIC_WHAT = ("transforms", "jacobian", "task")
SYMBOLIC_FORMATS = ("latex", "python", "c", "text")
#: time limit of a symbolic request when the caller gives none (seconds)
DEFAULT_SYMBOLIC_TIMEOUT = 60.0


@dataclass(frozen=True, eq=False)
class SymbolicAnswer:
    """Closed forms: ``forms`` (:class:`~kinematics.algorithms.symbolic.ClosedForms`, sympy
    matrices) and ``output`` (them rendered in the requested format, a JSON-ready dict)."""

    forms: Any
    output: dict[str, Any]

    @property
    def seconds(self) -> float:
        return float(self.forms.seconds)


def _task_layout(what: Sequence[str], representation: str | None, components: Sequence[str] | None):
    if "task" not in what:
        return None
    from .algorithms.task import task_representation

    return task_representation(representation or "rpy", components)


def _derive(chain, what, fmt, simplify, representation, components, prefix, timeout) -> SymbolicAnswer:
    from .algorithms import symbolic as _symbolic

    what = tuple(what)
    forms, output = _symbolic.derive(chain, what=what, simplify=simplify, fmt=fmt, prefix=prefix, timeout=timeout,
                                     task=_task_layout(what, representation, components))
    output["seconds"] = round(forms.seconds, 6)
    return SymbolicAnswer(forms, output)


def symbolic(model: RobotModel, *, tip: str | None = None, dh_table: dict | None = None,
             what: Sequence[str] = ("transforms",), fmt: str = "latex", simplify: bool = True,
             representation: str | None = None, components: Sequence[str] | None = None, variables: str = "q",
             prefix: str = "", timeout: float | None = DEFAULT_SYMBOLIC_TIMEOUT) -> SymbolicAnswer:
    """Closed forms of the chain from the model's root to ``tip`` (default: the only leaf link).

    ``dh_table``: the table the model was built from (a DH preset or DH-built model); then, for
    its tool (``tip`` None or ``"tool"``), the factors are the table's DH matrices. ``what``:
    ``transforms``, ``jacobian``, ``task`` (``representation`` and ``components`` of
    :mod:`kinematics.algorithms.task`); ``fmt``: ``latex``, ``python``, ``c``, ``text``;
    ``variables``: ``q`` (q1..qn) or ``names`` (the joint names); ``timeout`` (seconds, None:
    unbounded) bounds the whole derivation (:class:`~kinematics.errors.SymbolicTimeoutError`).
    """
    from .algorithms import symbolic as _symbolic
    from .io.dh_table import table_from_dict

    require_one_dof(model, "closed forms")
    if dh_table is not None and tip in (None, "tool"):
        chain = _symbolic.chain_from_table(table_from_dict(dh_table), variables=variables)
    else:
        chain = _symbolic.chain_from_model(model, tip=tip, variables=variables)
    return _derive(chain, what, fmt, simplify, representation, components, prefix, timeout)


def symbolic_dh(table: dict, *, what: Sequence[str] = ("transforms",), fmt: str = "latex", simplify: bool = True,
                representation: str | None = None, components: Sequence[str] | None = None, variables: str = "q",
                prefix: str = "", timeout: float | None = DEFAULT_SYMBOLIC_TIMEOUT) -> SymbolicAnswer:
    """Closed forms of a DH table whose entries may be parameter names or expressions
    (``{"a": "a1", "d": "-d4", "alpha": "pi/2"}``; :func:`~kinematics.algorithms.symbolic.symbolic_table_from_dict`);
    options as :func:`symbolic`. No model is built."""
    from .algorithms import symbolic as _symbolic

    chain = _symbolic.chain_from_table(_symbolic.symbolic_table_from_dict(table), variables=variables)
    return _derive(chain, what, fmt, simplify, representation, components, prefix, timeout)


@dataclass(frozen=True, eq=False)
class TaskAnswer(_Answer):
    """Task vectors ``r`` (N, m) and analytic Jacobians ``J_r`` (N, m, dof) of ``link``."""

    link: str
    representation: Any  # kinematics.algorithms.task.TaskRepresentation
    r: np.ndarray
    J_r: np.ndarray

    def conditioning(self) -> dict[str, np.ndarray]:
        """Singular values, manipulability and condition number of each ``J_r``."""
        return conditioning(self.J_r)


def task(model: RobotModel, q: Any, *, link: str | None = None, representation: str = "rpy",
         components: Sequence[str] | None = None, base: Any = None, point: Any = None, tool: Any = None,
         limits: str = "report", budget: Budget = UNBOUNDED) -> TaskAnswer:
    """Task vectors ``r = (p, phi)`` of ``link`` (None: the first leaf link) and their analytic
    Jacobians ``J_r = dr/dq = blockdiag(I, E(phi)^-1) J`` (:mod:`kinematics.algorithms.task`),
    for joint values ``q`` in the world of ``base``; ``point`` / ``tool``: of the frame at that
    offset from the link (as :func:`fk`); ``limits`` as :func:`fk`. At a singularity
    of the representation: :class:`~kinematics.errors.RepresentationSingularityError`.
    The Jacobian route's ``representation`` option answers this too."""
    from .algorithms.task import task as _task, task_representation

    rep = task_representation(representation, components)
    require_one_dof(model, "task vectors")
    Q, is_batch = _prepare(model, q, limits, budget)
    link = model.leaf_links[0] if link is None else link
    compile_model(model).link_indices([link])
    N = Q.shape[0]
    budget.check_result(N * rep.size * (model.dof + 1), f"{N} configurations x {rep.size} x ({model.dof} + 1)")
    r, J_r = _task(model, Q, link, rep, base_poses(base, N), tool_offset(point, tool))
    return TaskAnswer(model, Q, is_batch, link, rep, r, J_r)


#: the model descriptions the library reads, by kind: (reader of a dict, file reader, canonical dict, model)
def _descriptions():
    from .io import axes_model, dh_table, poe_model

    return {
        "dh": (dh_table.table_from_dict, dh_table.load_table,
               lambda t: dh_table.table_to_dict(t, angles="radians"), dh_table.model_from_table),
        "poe": (poe_model.poe_from_dict, poe_model.load_poe, poe_model.poe_to_dict, poe_model.model_from_poe),
        "axes": (axes_model.axes_from_dict, axes_model.load_axes, axes_model.axes_to_dict, axes_model.model_from_axes),
    }


DESCRIPTION_KINDS = ("dh", "poe", "axes")


def model_from_description(kind: str, description: Any, *, max_links: int | None = None
                           ) -> tuple[RobotModel, dict[str, Any]]:
    """``(model, canonical dict)`` of a model description: a DH table, a PoE description or a
    zero-configuration axes description (``kind``), given as a dict (the JSON of ``POST /models/<kind>``)
    or a ``.yaml``/``.json`` file path. The canonical dict (radians, every field explicit) reads back
    to the same model."""
    if kind not in DESCRIPTION_KINDS:
        raise KinematicsError(f"kind: {kind!r} is not one of {list(DESCRIPTION_KINDS)}")
    from_dict, load, to_dict, build = _descriptions()[kind]
    spec = from_dict(description) if isinstance(description, dict) else load(description)
    kwargs = {} if max_links is None else {"max_links": max_links}
    return build(spec, **kwargs), to_dict(spec)


def description_urdf(kind: str, description: Any) -> str:
    """The URDF text a description becomes (dict or file path, as :func:`model_from_description`)."""
    return model_from_description(kind, description)[0].urdf
