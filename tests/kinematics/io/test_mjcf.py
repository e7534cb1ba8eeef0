"""MJCF: MuJoCo's compiler resolves the document, the model is the URDF it becomes; every body
pose agrees with MuJoCo's own ``mj_kinematics`` (robots shipped by robosuite and gymnasium) and
Pinocchio reads the generated URDF; meshes are never opened."""

from __future__ import annotations

import sys
import threading
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from kinematics import compile_model  # noqa: E402
from kinematics.errors import MJCFError, UnsupportedJointError  # noqa: E402
from kinematics.io.mjcf import compile_mjcf, load_mjcf, parse_mjcf  # noqa: E402
from kinematics.tolerances import AGREEMENT_TOLERANCE  # noqa: E402
from kinematics.verify import pinocchio as crosscheck  # noqa: E402

from tests.paths import FIXTURES  # noqa: E402

SITE = Path(np.__file__).resolve().parents[1]
ROBOSUITE = SITE / "robosuite" / "models" / "assets"
GYM = SITE / "gymnasium" / "envs" / "mujoco" / "assets"
#: robosuite's robots without a free joint (gr1 and spot have one: FREE_JOINT_FILES below)
ROBOSUITE_ROBOTS = ["baxter", "iiwa", "jaco", "kinova3", "panda", "sawyer", "spot_arm", "tiago", "ur5e", "xarm7"]
GRIPPERS = ["panda_gripper", "robotiq_gripper_140", "robotiq_gripper_s", "jaco_three_finger_gripper",
            "inspire_left_hand", "fourier_right_hand", "rethink_gripper"]
GYM_MODELS = ["half_cheetah", "hopper", "walker2d", "swimmer", "reacher", "pusher", "inverted_double_pendulum", "point"]


def _files():
    out = [pytest.param(ROBOSUITE / "robots" / r / "robot.xml", id=f"robosuite-{r}") for r in ROBOSUITE_ROBOTS]
    out += [pytest.param(ROBOSUITE / "grippers" / f"{g}.xml", id=f"gripper-{g}") for g in GRIPPERS]
    out += [pytest.param(GYM / f"{g}.xml", id=f"gymnasium-{g}") for g in GYM_MODELS]
    return out


def body_poses(m, qpos: np.ndarray) -> np.ndarray:
    """MuJoCo's ``mj_kinematics``: (nbody, 4, 4) body poses at ``qpos``."""
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    T = np.tile(np.eye(4), (m.nbody, 1, 1))
    T[:, :3, :3] = d.xmat.reshape(-1, 3, 3)
    T[:, :3, 3] = d.xpos
    return T


def random_qpos(m, model, rng) -> tuple[np.ndarray, np.ndarray]:
    """(qpos for MuJoCo, q for our model): uniform within ranges, unlimited hinges over +-2 pi."""
    qpos, q = m.qpos0.copy(), np.zeros(model.dof)
    for j in range(m.njnt):
        lo, hi = m.jnt_range[j] if m.jnt_limited[j] else (-2 * np.pi, 2 * np.pi)
        v = rng.uniform(lo, hi)
        qpos[m.jnt_qposadr[j]] = v
        q[model.q_index[mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)]] = v
    return qpos, q


def agreement_with_mujoco(path: Path, rng, samples: int = 10) -> float:
    model = load_mjcf(path)
    m, _, _ = compile_mjcf(path.read_bytes(), base_dir=path.parent)
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}" for b in range(m.nbody)]
    names[0] = "world"
    poe = compile_model(model)
    worst = 0.0
    for _ in range(samples):
        qpos, q = random_qpos(m, model, rng)
        worst = max(worst, float(np.abs(poe.fk(q[None], names)[0] - body_poses(m, qpos)).max()))
    return worst


@pytest.mark.parametrize("path", _files())
def test_every_body_agrees_with_mujoco_and_pinocchio(path, rng):
    if not path.is_file():
        pytest.skip(f"{path} is not installed")
    assert agreement_with_mujoco(path, rng) < AGREEMENT_TOLERANCE
    model = load_mjcf(path)
    assert model.format == "mjcf"
    assert crosscheck.compare_fk(model, model.sample_configurations(3, rng)).worst < AGREEMENT_TOLERANCE


@pytest.mark.parametrize("robot", ["panda", "ur5e", "xarm7"])
def test_leaving_geometry_out_changes_no_pose(robot, rng):
    """MuJoCo compiling the original file (meshes and all) gives the same body poses as the reduced one."""
    path = ROBOSUITE / "robots" / robot / "robot.xml"
    if not path.is_file():
        pytest.skip("robosuite is not installed")
    full = mujoco.MjModel.from_xml_path(str(path))
    reduced, _, _ = compile_mjcf(path.read_bytes())
    assert full.nbody == reduced.nbody and full.njnt == reduced.njnt
    model = load_mjcf(path)
    for _ in range(5):
        qpos, _ = random_qpos(reduced, model, rng)
        np.testing.assert_allclose(body_poses(full, qpos), body_poses(reduced, qpos), atol=1e-12)


def _qpos_of(m, model, q: np.ndarray) -> np.ndarray:
    """MuJoCo's qpos of our q: a free joint's ``x y z qx qy qz qw`` becomes ``x y z qw qx qy qz``."""
    qpos = m.qpos0.copy()
    for j in range(m.njnt):
        s = model.slot[mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}"]
        a = int(m.jnt_qposadr[j])
        if s.type == "floating":
            x, y, z, qx, qy, qz, qw = q[s.q_slice]
            qpos[a:a + 7] = [x, y, z, qw, qx, qy, qz]
        else:
            qpos[a] = q[s.q_start]
    return qpos


FREE_JOINT_FILES = ([pytest.param(GYM / f"{g}.xml", id=f"gymnasium-{g}") for g in ("ant", "humanoid", "humanoidstandup")]
                    + [pytest.param(ROBOSUITE / "robots" / r / "robot.xml", id=f"robosuite-{r}") for r in ("gr1", "spot")])


@pytest.mark.parametrize("path", FREE_JOINT_FILES)
def test_free_joints_are_floating_joints_agreeing_with_mujoco_and_pinocchio(path, rng):
    """A free joint is a floating joint (7 entries of q, quaternion last as in Pinocchio): every body
    pose at random configurations (random unit quaternions) equals mj_kinematics at the qpos with the
    quaternion's w moved first, and Pinocchio's FK and Jacobians of the generated URDF."""
    if not path.is_file():
        pytest.skip(f"{path} is not installed")
    model = load_mjcf(path)
    m, _, _ = compile_mjcf(path.read_bytes(), base_dir=path.parent)
    free = [s for s in model.layout if s.type == "floating"]
    assert len(free) == 1 and free[0].q_start == 0 and model.nq == m.nq and model.nv == m.nv
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}" for b in range(m.nbody)]
    names[0] = "world"
    Q = model.sample_configurations(8, rng)
    ours = compile_model(model).fk(Q, names)
    worst = max(float(np.abs(ours[n] - body_poses(m, _qpos_of(m, model, q))).max()) for n, q in enumerate(Q))
    assert worst < AGREEMENT_TOLERANCE
    assert crosscheck.compare_fk(model, Q[:3]).worst < AGREEMENT_TOLERANCE
    leaf = model.leaf_links[0]
    assert crosscheck.compare_jacobian(model, Q[:3], leaf) < AGREEMENT_TOLERANCE


def test_free_joint_qpos_is_the_body_pose_in_the_world():
    model = parse_mjcf(FREE_BODY)
    m, _, _ = compile_mjcf(FREE_BODY)
    q = np.array([0.1, -0.2, 0.3, 0.0, 0.0, np.sin(0.25), np.cos(0.25), 0.4])  # a half-radian turn about z
    T = compile_model(model).fk(q[None], ["torso"])[0, 0]
    np.testing.assert_allclose(T[:3, 3], [0.1, -0.2, 0.3], atol=1e-15)
    np.testing.assert_allclose(T, body_poses(m, _qpos_of(m, model, q))[1], atol=1e-15)


FREE_BODY = """<mujoco model="free"><worldbody><body name="torso" pos="1 2 3" euler="0.1 0.2 0.3"><freejoint name="root"/>
<body name="leg" pos="0 0 -0.3"><joint name="hip" range="-1 1" axis="0 1 0"/></body></body></worldbody></mujoco>"""


def test_nested_free_joint_is_refused_by_mujoco():
    with pytest.raises(MJCFError, match="free joint can only be used on top level"):
        parse_mjcf(FREE_BODY.replace('<freejoint name="root"/>', "").replace(
            '<joint name="hip" range="-1 1" axis="0 1 0"/>', '<freejoint name="root"/>'))


ORIENTATIONS = """
<mujoco model="forms">
  <compiler angle="degree" eulerseq="zyx"/>
  <default><default class="arm"><joint axis="0 1 0" range="-90 90" damping="1"/></default></default>
  <worldbody>
    <body name="a" pos="0.1 0 0.2" quat="0.9 0.1 0.3 0.2" childclass="arm">
      <joint name="j1"/>
      <body name="b" pos="0 0.3 0" euler="10 20 30">
        <joint name="j2" type="slide" axis="1 1 0" range="-0.5 0.5" ref="0.1"/>
        <body name="c" axisangle="1 2 3 40" pos="0.2 0 0">
          <joint name="j3" pos="0 0 0.1" ref="15"/>
          <joint name="j4" axis="1 0 0" pos="0.05 0 0"/>
          <body name="d" xyaxes="0 1 0 -1 0 0.2">
            <joint name="j5" type="hinge" limited="false" pos="0.01 0.02 0.03"/>
            <body name="e" zaxis="1 1 1" pos="0 0 0.1"/>
            <frame pos="0 0.1 0" euler="0 0 90"><body name="f" pos="0.1 0 0"><joint name="j6"/></body></frame>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator><motor joint="j1"/></actuator>
  <equality><joint joint1="j3" joint2="j4"/></equality>
</mujoco>
"""


def test_every_orientation_form_default_class_ref_and_multi_joint_body(rng):
    model = parse_mjcf(ORIENTATIONS)
    assert model.joint_names == ("j1", "j2", "j3", "j4", "j5", "j6")
    assert model.joint_map["j1"].limits.upper == pytest.approx(np.pi / 2)  # childclass, degrees
    assert model.joint_map["j5"].type == "continuous"
    assert any("equality constraints are not applied" in w for w in model.warnings)
    m, _, _ = compile_mjcf(ORIENTATIONS)
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(m.nbody)]
    poe = compile_model(model)
    for _ in range(20):
        qpos, q = random_qpos(m, model, rng)
        np.testing.assert_allclose(poe.fk(q[None], names)[0], body_poses(m, qpos), atol=1e-12)
    assert crosscheck.compare_fk(model, model.sample_configurations(5, rng)).worst < 1e-12


def test_an_unlimited_slide_gets_wide_limits_and_a_warning():
    model = parse_mjcf('<mujoco><worldbody><body name="cart"><joint name="x" type="slide" axis="1 0 0"/>'
                       "</body></worldbody></mujoco>")
    assert model.joint_map["x"].limits.upper == 1e6
    assert any("slide joint 'x' has no range" in w for w in model.warnings)


def test_no_file_is_opened(tmp_path):
    """Meshes, textures and height fields the document names are never opened."""
    opened = []

    def hook(event, args):
        if event == "open" and threading.current_thread() is me:
            opened.append(str(args[0]))

    text = (FIXTURES / "descriptions" / "mjcf_mesh_file.xml").read_text()
    (tmp_path / "m.stl").write_text("solid")
    me = threading.current_thread()
    sys.addaudithook(hook)
    model = parse_mjcf(text.replace("/etc/passwd", str(tmp_path / "m.stl")))
    me = None  # the hook stays installed (hooks cannot be removed): stop recording
    assert model.joint_names == ("j",)
    assert not [o for o in opened if "passwd" in o or o.endswith(".stl")]


def test_not_mujoco_is_refused_naming_the_root():
    with pytest.raises(MJCFError, match="root element is <robot>"):
        parse_mjcf("<robot name='x'/>")


def test_mujoco_errors_name_the_element():
    with pytest.raises(MJCFError, match="(?s)MuJoCo refused the MJCF.*Element 'joint'"):
        parse_mjcf('<mujoco><worldbody><body name="a"><joint name="j" type="twist"/></body></worldbody></mujoco>')
