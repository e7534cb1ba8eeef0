"""The warm-up: every operation's compiled kernels loaded (or compiled) before a request needs them.

numba compiles a kernel on its first call in a process and keeps the result in its disk cache
(:mod:`kinematics.engine.compiled`): the first run on a machine compiles everything (minutes on
a busy 2-core machine), a later process loads the cache (a few seconds in all). What a request
must not do is compile: :func:`warm_up` calls each operation once on small robots, in
:data:`STEPS` order, so that every kernel signature the requests use is loaded, or compiled and
written to the cache. ``kinematics warm-up`` runs it at install (``make install``) and in the
Docker build, saying what it does and how long each step takes; the service runs the same steps
in a background thread at start (``app.warm``), answering meanwhile.

>>> [name for name, _ in steps()][:2]
['forward kinematics, Jacobians, velocity, workspace', 'one IK solution, task vectors']
"""

from __future__ import annotations

import time
from typing import Callable

import numpy as np

from ..errors import MissingExtraError
from ..io.catalogue import default_catalogue
from ..io.urdf import parse_urdf
from .calibration import calibrate, calibration_poses
from .collision import collision, collision_matrix
from .fk import fk
from .ik import ik
from .ik_all import ik_family, ik_path
from .jacobian import jacobian
from .query import model_for
from .task import task
from .trajectory import TrajectoryLimits, ToolSpeed, trajectory
from .velocity import velocity
from .workspace import workspace

#: A one-joint robot for the kernels every model shares.
_ONE_JOINT_URDF = """<robot name="warm_up">
  <link name="base"/><link name="arm"/>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>"""

#: A three-joint arm of boxes: self-collision, collision-free IK and paths, calibration poses.
_BOXES_URDF = """<robot name="warm_up_boxes">
  <link name="base"><collision><geometry><box size="0.2 0.2 0.1"/></geometry></collision></link>
  <link name="l1"><collision><origin xyz="0 0 0.2"/><geometry><box size="0.05 0.05 0.3"/></geometry></collision></link>
  <link name="l2"><collision><origin xyz="0.15 0 0"/><geometry><box size="0.3 0.04 0.04"/></geometry></collision></link>
  <link name="l3"><collision><origin xyz="0.1 0 0"/><geometry><sphere radius="0.03"/></geometry></collision></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><origin xyz="0 0 0.05"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0 0 0.35"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/><origin xyz="0.3 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
</robot>"""
#: configurations of the boxes' allowed-collision matrix (few: the kernels, not the matrix, are the point)
_BOX_SAMPLES = 50


def _basics() -> None:
    model = parse_urdf(_ONE_JOINT_URDF)
    fk(model, [0.5])
    fk(model, [0.0]).components()
    jacobian(model, [0.0], link="arm")
    fk(model, [[0.5], [0.0]])  # a batch (one row takes the single-configuration entries of engine/single.py)
    jacobian(model, [[0.0], [0.5]], link="arm")
    velocity(model, [0.0], [0.0])
    workspace(model, "arm", samples=8)


def _one_solution() -> None:
    model = parse_urdf(_ONE_JOINT_URDF)
    ik(model, fk(model, [0.5]).poses[0, 0], link="arm")
    arm = default_catalogue().get("ur5_dh")
    q = [0.3] * arm.dof
    task(arm, q)
    ik(arm, fk(arm, q).poses[0, -1])


def _every_solution() -> None:
    # the closed forms of three parallel axes and of spherical wrists (a revolute and a prismatic third joint)
    # and the compiled polish, limits ignored and with every 2 pi copy (engine/ik_fast.py, engine/ik_polish.py)
    for preset in ("ur5_dh", "puma560_standard", "stanford_arm"):
        arm = default_catalogue().get(preset)
        target = fk(arm, [0.3] * arm.dof).poses[0, -1]
        ik(arm, target, solutions="all", limits="ignore")
        ik(arm, target, solutions="all", limits="respect")
        ik_family(arm)
    arm = default_catalogue().get("ur5_dh")
    q = np.array([0.3, -1.0, 1.2, -0.5, 0.8, 0.2])
    start = fk(arm, q).poses[0, -1]
    end = start.copy()
    end[:3, 3] += [0.0, -0.1, 0.05]
    ik_path(arm, np.stack([start, end]), seed=q)


def _redundancy() -> None:
    # a 7-joint arm's self-motion: slices, intervals and the best point (algorithms/ik_redundant.py,
    # ik_self_motion.py): the Panda, its default parameter (q7, a spherical-shoulder closed form)
    panda = default_catalogue().get("panda")
    q = np.array([0.3, -0.5, 0.2, -2.0, 0.4, 1.8, 0.7, 0.0])
    target = fk(panda, q, links=["panda_link8"]).poses[0, 0]
    ik(panda, target, link="panda_link8", solutions="all",
       redundancy={"values": [0.7], "intervals": True, "select": "margin"})


def _trajectories() -> None:
    # the time-optimal passes, the jerk-limited profile and a tool's speed (algorithms/trajectory/)
    arm = default_catalogue().get("ur5_dh")
    waypoints = [[0.0] * 6, [0.3, -0.4, 0.5, 0.1, 0.2, 0.0], [0.6, -0.2, 0.3, 0.0, 0.4, 0.1]]
    for interpolation in ("spline", "linear"):
        trajectory(arm, waypoints, TrajectoryLimits(velocity=1.0, acceleration=2.0), interpolation=interpolation,
                   blend=0.05, rate=20)
    trajectory(arm, waypoints, TrajectoryLimits(velocity=1.0, acceleration=2.0, jerk=20.0), rate=20)
    trajectory(arm, waypoints, TrajectoryLimits(velocity=1.0, acceleration=2.0,
                                                tool_speed=ToolSpeed(link=arm.links[-1], max=0.5)), rate=20)


def _floating_base() -> None:
    # the kernels below a floating root joint (engine/rooted.py)
    model = parse_urdf(_ONE_JOINT_URDF)
    neutral = model_for(model, floating_base=True).neutral
    fk(model, neutral, floating_base=True)
    jacobian(model, neutral, link="arm", floating_base=True)


def _collisions_and_paths() -> None:
    arm = parse_urdf(_BOXES_URDF)
    q = [0.2, 0.4, -0.3]
    collision_matrix(arm, samples=_BOX_SAMPLES)
    collision(arm, q, samples=_BOX_SAMPLES)
    collision(arm, [q, q], distance=True, samples=_BOX_SAMPLES)
    target = fk(arm, q, links=["l3"]).poses[0, 0]
    ik(arm, target, link="l3", mode="position", avoid_collisions=True, collision_samples=_BOX_SAMPLES)
    moved = target.copy()
    moved[2, 3] -= 0.05
    ik_path(arm, np.stack([target, moved]), seed=q, link="l3", avoid_collisions=True,
            collision_samples=_BOX_SAMPLES)


def _calibration() -> None:
    arm = parse_urdf(_BOXES_URDF)
    calibration_poses(arm, 6, link="l3")
    # a calibration from twelve exact measurements: a process's first calibration took ~0.6 s more
    # than the next (first uses of scipy's least squares, loads), most of it holding the GIL, so a
    # server's event loop stood still while it ran (/health under calibrations: p99 of 0.2-1.4 s)
    Q = arm.sample_configurations(12, np.random.default_rng(0))
    P = fk(arm, Q, links=["l3"]).poses[:, 0, :3, 3]
    calibrate(arm, [{"q": q.tolist(), "position": p.tolist()} for q, p in zip(Q, P)], link="l3")


def _if_installed(step: Callable[[], None]) -> Callable[[], None]:
    """``step``, which does nothing when the extra it needs is not installed (nothing to warm up then)."""
    def run() -> None:
        try:
            step()
        except MissingExtraError:
            pass

    return run


def _catalogue() -> None:
    """Every bundled model read and compiled (a server's first request on one pays neither)."""
    from ..engine.poe import compile_model
    from ..errors import KinematicsError

    catalogue = default_catalogue()
    for model_id in catalogue.ids():
        try:
            compile_model(catalogue.get(model_id))
        except KinematicsError:  # a model that cannot be loaded or compiled answers its error on request
            continue


#: the steps of the warm-up: (what it loads, the function), compiled kernels first
STEPS: tuple[tuple[str, Callable[[], None]], ...] = (
    ("forward kinematics, Jacobians, velocity, workspace", _basics),
    ("one IK solution, task vectors", _one_solution),
    ("every IK solution (closed forms, polish), IK families", _every_solution),
    ("a 7-joint arm's self-motion (slices, intervals, best point)", _redundancy),
    ("trajectories (time-optimal, jerk-limited, tool speed)", _trajectories),
    ("a floating base", _floating_base),
    ("self-collision, collision-free IK and paths", _if_installed(_collisions_and_paths)),
    ("calibration poses and a calibration", _if_installed(_calibration)),
)
#: the step a long-running process adds (nothing of it stays on disk): the bundled models, read and compiled
CATALOGUE_STEP = ("the bundled models, read and compiled", _catalogue)


def steps(*, catalogue: bool = False) -> tuple[tuple[str, Callable[[], None]], ...]:
    """:data:`STEPS`, then :data:`CATALOGUE_STEP` when ``catalogue`` (a server: it keeps them in memory)."""
    return STEPS + ((CATALOGUE_STEP,) if catalogue else ())


def warm_up(progress: Callable[[str, float], None] | None = None, *, catalogue: bool = False) -> None:
    """Load every operation's compiled kernels now (compiled on the first run on a machine, then read
    from numba's disk cache), so that no request compiles one. ``progress(step, seconds)`` is told of
    each step once it is done."""
    for name, run in steps(catalogue=catalogue):
        t0 = time.perf_counter()
        run()
        if progress is not None:
            progress(name, time.perf_counter() - t0)
