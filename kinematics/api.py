"""The use cases: what the service's routes and the command line ask of the library.

"FK of these links for this q batch with this base, verified or not" is one call,
:func:`fk`; the Jacobian is :func:`jacobian`. Each validates the joint values (a vector, a
name map, or a list of those), applies the caller's :class:`Budget`, computes with the
compiled kernels, re-expresses the result in the world of the base pose, and on request
compares it with Pinocchio. The answers are plain objects of numpy arrays; turning them
into JSON or ``.npy`` is the caller's business.

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
from .algorithms.jacobian import jacobian as _jacobian
from .algorithms.measures import conditioning
from .engine.poe import compile_model
from .errors import BudgetError, JointValueError, KinematicsError
from .io.catalogue import default_catalogue
from .io.dh_table import load_table, model_from_table
from .io.poses import base_poses, pose_list
from .io.urdf import load_urdf, parse_urdf
from .model.joint_values import as_batch, limit_violations, out_of_limits, require_within_limits
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

    def as_dict(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if v is not None}


@dataclass(frozen=True, eq=False)
class _Answer:
    model: RobotModel
    Q: np.ndarray  # (N, dof), the validated joint values
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


def joint_batch(model: RobotModel, q: Any, budget: Budget = UNBOUNDED) -> tuple[np.ndarray, bool]:
    """``(Q (N, dof), is_batch)`` of joint values as a request gives them, within ``budget``.

    A list of equal-length number lists becomes one array at once (the common batch), so
    a large batch is not validated number by number; anything else (name maps, ragged
    lists) goes through :func:`~kinematics.model.as_batch`, which names what is wrong.
    """
    if isinstance(q, list) and q and isinstance(q[0], list):
        try:
            arr = np.array(q, dtype=float)
        except (TypeError, ValueError):  # ragged or not numbers: let as_batch name the configuration
            arr = None
        if arr is not None and arr.ndim == 2:
            q = arr
    Q, is_batch = as_batch(model, q)
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


def _prepare(model: RobotModel, q: Any, limits: str, budget: Budget) -> tuple[np.ndarray, bool]:
    if limits not in LIMIT_POLICIES:
        raise KinematicsError(f"limits: {limits!r} is not one of {', '.join(LIMIT_POLICIES)}")
    Q, is_batch = joint_batch(model, q, budget)
    if limits == "refuse":
        require_within_limits(model, Q)
    return Q, is_batch


def fk(model: RobotModel, q: Any, *, links: Sequence[str] | str | None = None, base: Any = None,
       verify: bool = False, limits: str = "report", budget: Budget = UNBOUNDED) -> FKAnswer:
    """Poses ``T_world_link`` of ``links`` (None: the leaf links; ``"all"``; or names) for joint
    values ``q``; ``base`` is the root link's world pose (one, or one per configuration, in
    any form :func:`~kinematics.io.poses.base_poses` reads). ``verify`` compares the poses
    (in the root frame) with Pinocchio's; ``limits="refuse"`` raises :class:`LimitError`."""
    Q, is_batch = _prepare(model, q, limits, budget)
    names = resolve_links(model, links)
    N = Q.shape[0]
    if verify:
        budget.check_verify(N)
    budget.check_result(N * len(names) * 16, f"{N} configurations x {len(names)} links x 16")
    B = base_poses(base, N)
    T = forward_kinematics(model, Q, names)
    verification = None
    if verify:
        from .verify.pinocchio import compare_fk

        dev = compare_fk(model, Q, names, poses=T)
        verification = Verification(dev.reference, max_position_error=dev.max_position_error,
                                    max_rotation_error=dev.max_rotation_error)
    return FKAnswer(model, Q, is_batch, names, poses_in_world(T, B), verification)


def jacobian(model: RobotModel, q: Any, *, link: str | None = None, reference: str = Reference.WORLD,
             base: Any = None, verify: bool = False, limits: str = "report",
             budget: Budget = UNBOUNDED) -> JacobianAnswer:
    """Jacobians (N, 6, dof) of ``link`` (None: the first leaf link) in ``reference``, for joint
    values ``q``, re-expressed in the world of ``base``; ``verify`` and ``limits`` as :func:`fk`."""
    Q, is_batch = _prepare(model, q, limits, budget)
    link = model.leaf_links[0] if link is None else link
    compile_model(model).link_indices([link])
    N = Q.shape[0]
    if verify:
        budget.check_verify(N)
    budget.check_result(N * 6 * model.dof, f"{N} configurations x 6 x {model.dof}")
    B = base_poses(base, N)
    J = _jacobian(model, Q, link, reference)
    verification = None
    if verify:
        from .verify.pinocchio import REFERENCE_NAME, compare_jacobian

        err = compare_jacobian(model, Q, link, references=(reference,), jacobians={reference: J})
        verification = Verification(REFERENCE_NAME, max_jacobian_error=err)
    return JacobianAnswer(model, Q, is_batch, link, Reference(reference), jacobian_in_world(J, B, reference),
                          verification)


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
       random_seed: int = 0, base: Any = None, verify: bool = False, budget: Budget = UNBOUNDED) -> IKAnswer:
    """Joint values putting ``link`` (None: the first leaf link) at ``target``: one pose or a list
    (any form :func:`~kinematics.io.poses.pose_list` reads, or an (N, 4, 4) array), ``T_world_link``.

    ``seed``: one q (vector or name map) for every target, or one per target; default the middle
    of the limits. ``base`` as for :func:`fk`. ``success`` holds only where the answer's FK is
    within the tolerances and the answer inside the limits (:mod:`kinematics.algorithms.ik`).
    ``verify``: Pinocchio's FK of every answer, against its target.
    """
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
            S, _ = as_batch(model, seed)
        except JointValueError as exc:
            raise JointValueError(f"seed: {exc}") from None
        if S.shape[0] not in (1, N):
            raise JointValueError(f"seed: {S.shape[0]} seeds for {N} targets (give one, or one per target)")
        seeds = S
    B = base_poses(base, N)
    B = None if B is None else np.ascontiguousarray(B)
    solution = inverse_kinematics(model, link, T, seeds, base=B, mode=mode, position_tolerance=position_tolerance,
                                  rotation_tolerance=rotation_tolerance, max_iterations=max_iterations,
                                  restarts=restarts, random_seed=random_seed)
    verification = None
    if verify:
        from .verify.pinocchio import REFERENCE_NAME, reference_for

        ref = reference_for(model)
        theirs = np.array([ref.poses(q)[link] for q in solution.q]).reshape(N, 4, 4)
        T_root = T if B is None else np.matmul(inverse_transform(B), T)
        position, rotation = pose_errors(theirs, T_root)
        verification = {"reference": REFERENCE_NAME, "position_error": position, "rotation_error": rotation}
    return IKAnswer(model, link, mode, is_batch, T, solution, verification)


def load_model(*, model_id: str | None = None, urdf: str | None = None, dh: str | None = None) -> RobotModel:
    """The model of a catalogue id, a URDF file or a DH table file (exactly one of them)."""
    if sum(x is not None for x in (model_id, urdf, dh)) != 1:
        raise KinematicsError("name exactly one model: a catalogue id, a URDF file or a DH table file")
    if model_id is not None:
        return default_catalogue().get(model_id)
    if urdf is not None:
        return load_urdf(urdf)
    return model_from_table(load_table(dh))


#: A one-joint robot for :func:`warm_up`.
_WARM_UP_URDF = """<robot name="warm_up">
  <link name="base"/><link name="arm"/>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>"""


def warm_up() -> None:
    """Import the URDF parser stack and load the compiled kernels now (FK, Jacobian, IK, rotation
    to quaternion; compiled on the first run on a machine, a few seconds, then read from
    numba's disk cache), so that a server's first request pays for neither."""
    model = parse_urdf(_WARM_UP_URDF)
    pose = fk(model, [0.5]).poses[0, 0]
    fk(model, [0.0]).components()
    jacobian(model, [0.0], link="arm")
    ik(model, pose, link="arm")


def screws(model: RobotModel):
    """The model's product-of-exponentials parameters (:class:`~kinematics.engine.poe.PoEModel`):
    space screws ``S`` (angular first), axes ``w``, points ``r``, home poses ``M``."""
    return compile_model(model)


def dh_form(model: RobotModel, tip: str | None = None, convention: str = "standard"):
    """The DH table (:class:`~kinematics.io.dh_table.DHTable`) of the chain from the root to
    ``tip``, with base and tool; :class:`NoDHFormError` when the chain has none."""
    return urdf_to_dh(model, tip=tip, convention=convention)


def reference_name() -> str:
    """The reference library requests are verified against, with its version (``pinocchio 4.1.0``)."""
    from .verify.pinocchio import REFERENCE_NAME

    return REFERENCE_NAME
