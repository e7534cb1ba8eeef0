"""``floating_base``: a free-flyer root joint as Pinocchio's ``buildModelFromUrdf(path, JointModelFreeFlyer())``."""

from __future__ import annotations

import numpy as np

from kinematics.engine.poe import compile_model
from kinematics.io.floating import with_floating_base
from kinematics.io.urdf import parse_urdf


def test_structure_and_cache(catalogue):
    solo = catalogue.get("solo12")
    fb = with_floating_base(solo)
    assert fb is with_floating_base(solo) and fb.base_model is solo
    assert fb.joint_names == ("root_joint",) + solo.joint_names
    assert (fb.nq, fb.nv) == (7 + solo.nq, 6 + solo.nv)
    assert fb.root == "universe" and fb.links == ("universe",) + solo.links
    assert fb.parent_joint[solo.root].type == "floating" and fb.leaf_links == solo.leaf_links


def test_the_urdf_text_reads_back_to_the_same_model(catalogue, rng):
    fb = with_floating_base(catalogue.get("anymal_c"))
    again = parse_urdf(fb.urdf)
    assert again.joint_names == fb.joint_names and again.links[0] == "universe" and again.root == "universe"
    Q = fb.sample_configurations(3, rng)
    np.testing.assert_allclose(compile_model(again).fk(Q), compile_model(fb).fk(Q), atol=1e-15)


def test_the_root_pose_is_the_first_seven_entries_and_the_rest_is_the_fixed_base_fk(catalogue, rng):
    ur5 = catalogue.get("ur5")
    fb = with_floating_base(ur5)
    q = ur5.sample_configurations(1, rng)[0]
    T = compile_model(fb).fk(np.concatenate([fb.neutral[:7], q])[None], list(ur5.links))
    np.testing.assert_allclose(T[0], compile_model(ur5).fk(q[None])[0], atol=1e-12)


def test_names_already_taken_get_a_suffix():
    text = ('<robot name="r"><link name="universe"/><link name="b"/><joint name="root_joint" type="revolute">'
            '<parent link="universe"/><child link="b"/><axis xyz="0 0 1"/>'
            '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>')
    fb = with_floating_base(parse_urdf(text))
    assert fb.joint_names == ("root_joint_2", "root_joint") and fb.root == "universe_2"


def test_file_pipelines_refuse_several_values_per_joint_naming_why(catalogue, tmp_path):
    """Trajectory, Parquet and log readers take one column per joint: a floating base is refused
    with a message, never read as if q had one value per joint."""
    import pytest

    from kinematics.engine.single import fk_function
    from kinematics.errors import UnsupportedJointError
    from kinematics.io.trajectory import JointRows, TrajectoryFileError

    fb = with_floating_base(catalogue.get("ur5"))
    (tmp_path / "q.csv").write_text("0,0,0,0,0,0\n")
    with pytest.raises(TrajectoryFileError, match="floating joints .*one column per joint"):
        JointRows(str(tmp_path / "q.csv"), fb, "csv", "q.csv")
    with pytest.raises(UnsupportedJointError, match="single-configuration entries"):
        fk_function(fb, "tool0")
