"""The warm-up (kinematics.usecases.warm) loads every kernel the operations use: after it, no operation
compiles (or loads) a kernel signature, checked in a fresh process by counting each numba dispatcher's
signatures before and after every operation; and `kinematics warm-up` says what it does."""

from __future__ import annotations

import json
import subprocess
import sys

from tests.paths import REPO

#: a fresh process: warm up, then each operation once, reporting the kernel signatures each one added
_PROBE = r'''
import json, sys
import numpy as np
from numba.core.registry import CPUDispatcher
import kinematics
from kinematics import default_catalogue, fk, ik, jacobian, task, velocity, workspace
from kinematics.usecases import calibrate, calibration_poses, collision, ik_family, ik_path
from kinematics.usecases.trajectory import ToolSpeed, TrajectoryLimits, trajectory

def counts():
    return {f"{m.__name__}.{k}": len(v.signatures) for m in list(sys.modules.values())
            if (getattr(m, "__name__", None) or "").startswith("kinematics.")
            for k, v in list(vars(m).items()) if isinstance(v, CPUDispatcher)}

kinematics.warm_up()
cat = default_catalogue()
ur5, panda = cat.get("ur5"), cat.get("panda")
q = np.array([0.3, -1.0, 1.2, -0.5, 0.8, 0.2])
T = fk(ur5, q, links=["tool0"]).poses[0, 0]
T2 = T.copy(); T2[2, 3] += 0.05
P = fk(panda, [0.1] * panda.dof, links=["panda_hand"]).poses[0, 0]
P2 = P.copy(); P2[1, 3] += 0.02
operations = {
    "fk": lambda: fk(ur5, q, links=["tool0"]),
    "fk batch": lambda: fk(ur5, np.tile(q, (300, 1))),
    "fk floating base": lambda: fk(ur5, [0, 0, 0, 0, 0, 0, 1, *q], floating_base=True),
    "jacobian": lambda: jacobian(ur5, q, link="tool0", reference="local"),
    "jacobian batch": lambda: jacobian(ur5, np.tile(q, (300, 1)), link="tool0"),
    "velocity": lambda: velocity(ur5, q, q),
    "task": lambda: task(ur5, q, link="tool0"),
    "ik": lambda: ik(ur5, np.stack([T] * 3), link="tool0"),
    "ik every solution": lambda: ik(ur5, T, link="tool0", solutions="all"),
    "ik every solution, redundant": lambda: ik(panda, P, link="panda_hand", solutions="all",
                                               locked={"panda_joint7": 0.1}),
    "ik avoid_collisions": lambda: ik(ur5, T, link="tool0", avoid_collisions=True, collision_samples=100),
    "ik path": lambda: ik_path(ur5, np.stack([T, T2]), seed=q, link="tool0", avoid_collisions=True,
                               collision_samples=100),
    "ik family": lambda: ik_family(ur5),
    "collision": lambda: collision(panda, [0.0] * panda.dof, samples=100, distance=True),
    "calibration poses": lambda: calibration_poses(ur5, 8, link="tool0"),
    "calibrate": lambda: calibrate(ur5, [{"q": (q + 0.1 * k).tolist(), "position": fk(ur5, q + 0.1 * k,
                                          links=["tool0"]).poses[0, 0, :3, 3].tolist()} for k in range(10)],
                                   link="tool0"),
    "workspace": lambda: workspace(ur5, "tool0", samples=500),
    "ik self-motion": lambda: ik(panda, P, link="panda_hand", solutions="all",
                                 redundancy={"values": [0.1, 0.4], "intervals": True, "select": "nearest"}),
    "ik path along the self-motion": lambda: ik_path(panda, np.stack([P, P2]), seed=[0.1] * panda.dof,
                                                     link="panda_hand", redundancy={"select": "nearest"}),
    "trajectory": lambda: trajectory(ur5, np.stack([q, q + 0.3, q - 0.2]), TrajectoryLimits(acceleration=2.0)),
    "trajectory, jerk-limited, tool speed": lambda: trajectory(
        ur5, np.stack([q, q + 0.3]), TrajectoryLimits(acceleration=2.0, jerk=30.0, tool_speed=ToolSpeed("tool0", 0.3))),
}
added, imported = {}, {}
for name, run in operations.items():
    before, modules = counts(), set(sys.modules)
    run()
    after = counts()
    added[name] = sorted(k for k in after if after[k] > before.get(k, 0))
    imported[name] = sorted(m for m in set(sys.modules) - modules if m.split(".")[0] in ("scipy", "kinematics"))
print(json.dumps({"kernels": len(counts()), "added": added, "imported": imported}))
'''


def test_after_the_warm_up_no_operation_loads_or_compiles_a_kernel():
    out = subprocess.run([sys.executable, "-c", _PROBE], cwd=REPO, capture_output=True, text=True, check=True)
    report = json.loads(out.stdout.strip().splitlines()[-1])
    assert report["kernels"] > 20  # the probe sees the dispatchers (a probe that sees none would pass blindly)
    assert {name: kernels for name, kernels in report["added"].items() if kernels} == {}
    # nor imports a module of the library or of scipy (an import holds the GIL throughout)
    assert {name: modules for name, modules in report["imported"].items() if modules} == {}


def test_the_command_says_each_step_and_its_time(capsys):
    from kinematics.cli import main
    from kinematics.usecases.warm import STEPS

    assert main(["warm-up"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("warm-up: loading the compiled kernels")
    for name, _ in STEPS:
        assert f" s  {name}\n" in out
    assert out.rstrip().splitlines()[-1].startswith("warm-up: done in ")
