"""Inverse kinematics (kinematics.algorithms.ik, kinematics.api.ik): reachable targets are solved
inside the limits, every claimed success is true (checked here again with Pinocchio), and
unreachable or bad requests get honest answers."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import api, compile_model, default_catalogue, load_urdf
from kinematics.algorithms.ik import STALL_STEPS, inverse_kinematics, middle_of_limits, pose_errors
from kinematics.errors import BudgetError, JointValueError, KinematicsError, PoseError, UnknownLinkError
from kinematics.model.joint_values import limit_violations
from kinematics.spatial.rotations import rpy_to_matrix
from kinematics.verify.pinocchio import reference_for
from tests.paths import FIXTURES

TOL = 1e-6


@pytest.fixture(scope="module")
def catalogue():
    return default_catalogue()


def _targets(model, link, n, seed=7):
    """FK of ``n`` random configurations within the limits (continuous joints within a turn)."""
    Q = model.sample_configurations(n, np.random.default_rng(seed), continuous_range=np.pi)
    return Q, compile_model(model).fk(Q, [link])[:, 0]


def _check_successes(model, link, sol, targets, mode="pose", base=None):
    """Every success is true: Pinocchio's FK of the answer is within the tolerance of the
    target, and the answer is inside the limits; every answer (solved or not) is inside them."""
    assert sol.q.shape == (len(targets), model.dof) and np.all(np.isfinite(sol.q))
    assert not limit_violations(model, sol.q).any(), "an answer outside the joint limits"
    ref = reference_for(model)
    T_root = targets if base is None else np.linalg.inv(base) @ targets
    theirs = np.array([ref.poses(q)[link] for q in sol.q])
    position, rotation = pose_errors(theirs, T_root)
    ok = sol.success
    assert np.all(position[ok] <= TOL + 1e-12)
    if mode == "pose":
        assert np.all(rotation[ok] <= TOL + 1e-12)
    np.testing.assert_allclose(sol.position_error, position, atol=1e-12)


@pytest.mark.parametrize("model_id, link", [("ur5", "tool0"), ("panda", "panda_link8"), ("kuka_lwr4", "tool"),
                                            ("xarm7", "link_eef"), ("stanford_arm", "tool")])
def test_reachable_targets_are_solved_inside_the_limits(catalogue, model_id, link):
    model = catalogue.get(model_id)
    _, T = _targets(model, link, 40)
    sol = inverse_kinematics(model, link, T)
    assert sol.success.all(), f"{(~sol.success).sum()} of {len(T)} reachable targets not solved"
    _check_successes(model, link, sol, T)


def test_prismatic_joints_scara(catalogue):
    """The SCARA's quill is prismatic: solved in position mode (its 4 joints cannot set a full pose)."""
    model = catalogue.get("scara")
    _, T = _targets(model, "tool", 30)
    sol = inverse_kinematics(model, "tool", T, mode="position")
    assert sol.success.all()
    _check_successes(model, "tool", sol, T, mode="position")


def test_position_mode_on_a_five_dof_arm(catalogue):
    """so100's gripper link hangs from 5 joints: any reachable position is solved, orientation free."""
    model = catalogue.get("so100")
    _, T = _targets(model, "gripper", 30)
    sol = inverse_kinematics(model, "gripper", T, mode="position")
    assert sol.success.all()
    _check_successes(model, "gripper", sol, T, mode="position")
    assert np.any(sol.rotation_error > 1e-3)  # the orientation was free, and was not matched by chance


def test_a_tree_moves_only_the_path_to_the_link(catalogue):
    """Talos' left arm: the legs, torso-free joints and the other arm keep the seed's values."""
    model = catalogue.get("talos_reduced")
    link = "arm_left_7_link"
    Q, T = _targets(model, link, 10)
    seeds = model.sample_configurations(10, np.random.default_rng(3))
    sol = inverse_kinematics(model, link, T, seeds)
    assert sol.success.all()
    _check_successes(model, link, sol, T)
    on_path = {j.name for j in model.path_joints(link)}
    off = [model.q_index[n] for n in model.joint_names if n not in on_path]
    np.testing.assert_array_equal(sol.q[:, off], seeds[:, off])


def test_mimic_and_continuous_joints():
    """tree_mimic: a continuous joint (wrapped into [-pi, pi]) and a mimic joint following a leader."""
    model = load_urdf(FIXTURES / "tree_mimic.urdf")
    for link in model.leaf_links:
        if not any(j.moving for j in model.path_joints(link)):
            continue
        _, T = _targets(model, link, 15)
        sol = inverse_kinematics(model, link, T, mode="position")
        assert sol.success.all(), link
        _check_successes(model, link, sol, T, mode="position")
    cont = [model.q_index[j.name] for j in model.joints if j.type == "continuous"]
    assert cont and np.all(np.abs(sol.q[:, cont]) <= np.pi + 1e-12)


def test_singular_target_stretched_ur5(catalogue):
    """The arm stretched out (shoulder and elbow aligned): a singular configuration, still solved."""
    model = catalogue.get("ur5")
    q = np.array([[0.3, -np.pi / 2, 0.0, -np.pi / 2, 0.4, 0.2]])  # upper arm and forearm in line
    T = compile_model(model).fk(q, ["tool0"])[:, 0]
    sol = inverse_kinematics(model, "tool0", T)
    assert sol.success.all()
    _check_successes(model, "tool0", sol, T)


def test_unreachable_target_best_effort(catalogue):
    model = catalogue.get("ur5")
    T = np.eye(4)[None].repeat(2, axis=0)
    T[0, :3, 3] = [5.0, 0.0, 0.0]  # far beyond the reach (about 1 m)
    T[1, :3, 3] = [0.3, 0.2, 0.4]
    sol = inverse_kinematics(model, "tool0", T, max_iterations=30, restarts=3)
    assert not sol.success[0]
    assert np.all(np.isfinite(sol.q)) and 3.5 < sol.position_error[0] < 5.0  # the best found: as near as it gets
    # four attempts, each ended by its step limit or as stuck (no progress for STALL_STEPS steps)
    assert 4 * (STALL_STEPS + 1) <= sol.iterations[0] <= 4 * 30
    assert not limit_violations(model, sol.q).any()


def test_batch_answers_equal_single_answers_and_are_reproducible(catalogue):
    model = catalogue.get("panda")
    _, T = _targets(model, "panda_link8", 12, seed=11)
    batch = inverse_kinematics(model, "panda_link8", T, random_seed=5, restarts=20)
    for i in (0, 5, 11):
        one = inverse_kinematics(model, "panda_link8", T[i:i + 1], random_seed=5, restarts=20)
        np.testing.assert_array_equal(one.q[0], batch.q[i])
        assert one.iterations[0] == batch.iterations[i]
    again = inverse_kinematics(model, "panda_link8", T, random_seed=5, restarts=20)
    np.testing.assert_array_equal(again.q, batch.q)


def test_random_seed_changes_the_restarts(catalogue):
    """Targets that need restarts get different draws under another random seed."""
    model = catalogue.get("panda")
    _, T = _targets(model, "panda_link8", 40, seed=2)
    a = inverse_kinematics(model, "panda_link8", T, random_seed=1, max_iterations=5, restarts=3)
    b = inverse_kinematics(model, "panda_link8", T, random_seed=2, max_iterations=5, restarts=3)
    restarted = (a.iterations > 5) & (b.iterations > 5)
    assert restarted.any() and not np.array_equal(a.q[restarted], b.q[restarted])


def test_seed_is_used_and_a_solved_seed_takes_no_step(catalogue):
    model = catalogue.get("ur5")
    Q, T = _targets(model, "tool0", 3)
    sol = inverse_kinematics(model, "tool0", T, Q)
    assert sol.success.all() and np.all(sol.iterations == 0)
    np.testing.assert_array_equal(sol.q, Q)
    np.testing.assert_array_equal(middle_of_limits(model), 0.5 * (model.lower_limits + model.upper_limits))


def test_base_pose(catalogue):
    model = catalogue.get("ur5")
    Q, T_root = _targets(model, "tool0", 5)
    B = np.eye(4)
    B[:3, :3] = rpy_to_matrix([0.1, -0.2, 0.7])
    B[:3, 3] = [1.0, -0.5, 0.3]
    T_world = B @ T_root
    sol = inverse_kinematics(model, "tool0", T_world, base=np.broadcast_to(B, (5, 4, 4)))
    assert sol.success.all()
    _check_successes(model, "tool0", sol, T_world, base=B)


def test_a_limited_joint_range_is_respected(catalogue):
    """A target reachable only outside one joint's (narrowed) range is not claimed as solved."""
    model = catalogue.get("planar_2r")
    T = compile_model(model).fk(np.array([[0.3, 1.2]]), ["tool"])[:, 0]
    ok = inverse_kinematics(model, "tool", T, mode="position")
    assert ok.success.all()
    narrow = load_urdf_with_limits(model, "joint_2", (-0.2, 0.2))  # elbow nearly straight: cannot fold to reach
    sol = inverse_kinematics(narrow, "tool", T, mode="position", restarts=5)
    assert not sol.success[0] and -0.2 - 1e-12 <= sol.q[0, 1] <= 0.2 + 1e-12


def load_urdf_with_limits(model, joint, limits):
    from kinematics import parse_urdf

    text = model.urdf
    j = model.joint_map[joint]
    old = f'lower="{j.limits.lower!r}" upper="{j.limits.upper!r}"'
    assert old in text, old
    return parse_urdf(text.replace(old, f'lower="{limits[0]}" upper="{limits[1]}"'))


# ---------------------------------------------------------------------- the use case (api.ik)
def test_api_accepts_every_pose_form_and_verifies(catalogue):
    model = catalogue.get("ur5")
    _, T = _targets(model, "tool0", 1)
    from kinematics.spatial.transforms import pose_components

    c = pose_components(T[0])
    w, x, y, z = c["quaternion"]
    forms = [T[0].tolist(), {"xyz": c["position"].tolist(), "rpy": c["rpy"].tolist()},
             {"position": c["position"].tolist(), "quaternion": {"w": w, "x": x, "y": y, "z": z}}]
    for form in forms:
        answer = api.ik(model, form, link="tool0", verify=True)
        assert not answer.is_batch and answer.solution.success.all()
        assert answer.verification["position_error"][0] <= TOL and answer.verification["rotation_error"][0] <= TOL
        assert answer.verification["reference"].startswith("pinocchio")
    batch = api.ik(model, forms, link="tool0")
    assert batch.is_batch and batch.solution.q.shape == (3, 6) and batch.solution.success.all()


@pytest.mark.parametrize("target, message", [
    ({"xyz": [0.1, 0.2, float("nan")], "rpy": [0, 0, 0]}, "target.xyz"),
    ([[1, 0, 0, 0], [0, 2, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "not a rigid transform"),
    ({"position": [0, 0, 0.5], "quaternion": {"w": 2, "x": 0, "y": 0, "z": 0}}, "not a unit quaternion"),
    ([], "empty"),
])
def test_bad_targets_are_refused_naming_them(catalogue, target, message):
    with pytest.raises(PoseError, match=message):
        api.ik(catalogue.get("ur5"), target)


def test_bad_options_are_refused(catalogue):
    model = catalogue.get("ur5")
    target = {"xyz": [0.4, 0.1, 0.3], "rpy": [0, 0, 0]}
    with pytest.raises(JointValueError, match="seed"):
        api.ik(model, target, seed=[0.0, 0.0])
    with pytest.raises(JointValueError, match="2 seeds for 1 targets"):
        api.ik(model, target, seed=[[0.0] * 6, [0.0] * 6])
    with pytest.raises(UnknownLinkError):
        api.ik(model, target, link="no_such_link")
    with pytest.raises(KinematicsError, match="mode"):
        api.ik(model, target, mode="orientation")
    with pytest.raises(KinematicsError, match="tolerance.position"):
        api.ik(model, target, position_tolerance=0.0)
    with pytest.raises(BudgetError, match="max_ik_work") as exc:
        api.ik(model, [target] * 10, max_iterations=100, restarts=9, budget=api.Budget(max_ik_work=9_999))
    assert exc.value.budget == "ik-work" and exc.value.limit == 9_999
    api.ik(model, [target] * 10, max_iterations=100, restarts=9, budget=api.Budget(max_ik_work=10_000))  # at the bound


def test_one_pose_and_a_batch_of_one_are_checked_alike():
    """A single (4, 4) target is checked in Python (io.poses._one_pose_problem), a batch as arrays: the
    same verdicts and words on good and bad poses."""
    from kinematics.errors import PoseError
    from kinematics.io.poses import pose_list

    rng = np.random.default_rng(5)
    good = np.eye(4)
    good[:3, :3] = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    good[:3, :3] *= np.sign(np.linalg.det(good[:3, :3]))
    good[:3, 3] = [0.3, -0.2, 0.5]
    cases = [good]
    for r, c, v in ((0, 0, np.nan), (1, 3, np.inf), (2, 3, 2e6), (0, 1, good[0, 1] + 1e-3), (3, 0, 1e-3),
                    (3, 3, 1.0 + 1e-4), (0, 0, good[0, 0] + 2e-6)):
        bad = good.copy()
        bad[r, c] = v
        cases.append(bad)
    cases.append(np.diag([1.0, 1.0, -1.0, 1.0]))  # a reflection: orthonormal, det -1
    for T in cases:
        def verdict(value):
            try:
                return pose_list(value, "target")[0][0].tolist()
            except PoseError as exc:
                return str(exc)
        one, batch = verdict(T), verdict(T[None])
        assert one == batch
    assert isinstance(verdict(good), list) and "not a rigid transform" in verdict(cases[-1])
