"""Joint values as users give them (kinematics.model.joint_values): as_batch, its error
messages, and the limit checks with LIMIT_TOLERANCE."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import JointValueError, LimitError, load_urdf
from kinematics.model.joint_values import as_batch, limit_violations, out_of_limits, require_within_limits
from kinematics.tolerances import LIMIT_TOLERANCE

from tests.paths import FIXTURES


@pytest.fixture(scope="module")
def tree():
    """Five independent joints (right_shoulder continuous), one mimic joint (right_finger_joint)."""
    return load_urdf(FIXTURES / "tree_mimic.urdf")


@pytest.fixture(scope="module")
def planar():
    """q1, q2 within +-3.14159."""
    return load_urdf(FIXTURES / "planar_2r.urdf")


def test_fixture_joint_order(tree):
    assert tree.joint_names == ("right_shoulder", "torso_joint", "left_shoulder", "left_elbow", "right_slide_joint")


# ---------------------------------------------------------------------- as_batch
def test_vector(tree):
    Q, batch = as_batch(tree, [0.1, 0.2, 0.3, 0.4, 0.05])
    assert batch is False
    assert Q.shape == (1, 5) and Q.dtype == np.float64
    np.testing.assert_array_equal(Q, [[0.1, 0.2, 0.3, 0.4, 0.05]])
    Q, batch = as_batch(tree, (1, 2, 0, 0, 0))  # a tuple of ints
    assert batch is False and Q.dtype == np.float64
    np.testing.assert_array_equal(Q, [[1.0, 2.0, 0.0, 0.0, 0.0]])


def test_name_map_is_put_in_q_order(tree):
    values = {"right_slide_joint": 0.05, "left_elbow": 0.4, "torso_joint": 0.2, "right_shoulder": 0.1,
              "left_shoulder": 0.3}
    Q, batch = as_batch(tree, values)
    assert batch is False
    np.testing.assert_array_equal(Q, [[0.1, 0.2, 0.3, 0.4, 0.05]])


def test_batch_of_vectors_and_maps(tree):
    names = tree.joint_names
    Q, batch = as_batch(tree, [[0.0] * 5, dict(zip(names, [1.0, 2.0, 3.0, 4.0, 5.0])), (5, 4, 3, 2, 1)])
    assert batch is True
    np.testing.assert_array_equal(Q, [[0.0] * 5, [1.0, 2.0, 3.0, 4.0, 5.0], [5.0, 4.0, 3.0, 2.0, 1.0]])


def test_numpy_arrays(tree):
    Q, batch = as_batch(tree, np.arange(5))
    assert batch is False and Q.shape == (1, 5) and Q.dtype == np.float64
    np.testing.assert_array_equal(Q, [[0.0, 1.0, 2.0, 3.0, 4.0]])
    arr = np.arange(15, dtype=np.float32).reshape(3, 5)
    Q, batch = as_batch(tree, arr)
    assert batch is True and Q.shape == (3, 5) and Q.dtype == np.float64
    np.testing.assert_array_equal(Q, arr)
    with pytest.raises(JointValueError, match="expected 5"):
        as_batch(tree, np.zeros((2, 4)))
    with pytest.raises(JointValueError, match="shape"):
        as_batch(tree, np.zeros((2, 2, 5)))
    with pytest.raises(JointValueError, match="dtype"):
        as_batch(tree, np.array(["a"] * 5))


def test_nan_names_the_joint(tree):
    with pytest.raises(JointValueError, match="'left_shoulder'") as err:
        as_batch(tree, [0.0, 0.0, float("nan"), 0.0, 0.0])
    assert "configuration" not in str(err.value)
    with pytest.raises(JointValueError, match="configuration 1, joint 'torso_joint'"):
        as_batch(tree, [[0.0] * 5, [0.0, float("inf"), 0.0, 0.0, 0.0]])
    with pytest.raises(JointValueError, match="configuration 2, joint 'right_slide_joint'"):
        as_batch(tree, np.array([[0.0] * 5, [0.0] * 5, [0.0, 0.0, 0.0, 0.0, np.nan]]))
    with pytest.raises(JointValueError, match="'left_elbow'"):
        as_batch(tree, dict(zip(tree.joint_names, [0.0, 0.0, 0.0, float("-inf"), 0.0])))


def test_huge_value_names_the_joint(tree):
    with pytest.raises(JointValueError, match="'right_shoulder'"):
        as_batch(tree, [1e9, 0.0, 0.0, 0.0, 0.0])


def test_wrong_length(tree):
    with pytest.raises(JointValueError, match="expected 5 joint values.*got 4"):
        as_batch(tree, [0.0] * 4)
    with pytest.raises(JointValueError, match="configuration 1: expected 5 joint values.*got 6"):
        as_batch(tree, [[0.0] * 5, [0.0] * 6])


def test_not_numbers(tree):
    with pytest.raises(JointValueError, match="'torso_joint'.*not a number"):
        as_batch(tree, [0.0, "1", 0.0, 0.0, 0.0])
    with pytest.raises(JointValueError, match="'right_shoulder'.*not a number"):
        as_batch(tree, [True, 0.0, 0.0, 0.0, 0.0])
    with pytest.raises(JointValueError, match="mixes"):
        as_batch(tree, [0.0, [0.0], 0.0, 0.0, 0.0])
    with pytest.raises(JointValueError):
        as_batch(tree, "0 0 0 0 0")
    with pytest.raises(JointValueError):
        as_batch(tree, 0.0)


def test_unknown_and_missing_names(tree):
    values = dict(zip(tree.joint_names, [0.0] * 5))
    with pytest.raises(JointValueError, match="unknown joint name.*elbow_typo"):
        as_batch(tree, {**values, "elbow_typo": 0.0})
    partial = {k: v for k, v in values.items() if k != "left_elbow"}
    with pytest.raises(JointValueError, match="missing value.*left_elbow") as err:
        as_batch(tree, partial)
    assert "right_shoulder" not in str(err.value)
    with pytest.raises(JointValueError, match="configuration 1: missing value.*left_elbow"):
        as_batch(tree, [values, partial])
    # a fixed joint is not a joint value either (and is not called a mimic joint)
    with pytest.raises(JointValueError, match="neck") as err:
        as_batch(tree, {**values, "neck": 0.0})
    assert "mimic" not in str(err.value)


def test_mimic_name_hint(tree):
    values = dict(zip(tree.joint_names, [0.0] * 5))
    with pytest.raises(JointValueError, match="right_finger_joint is a mimic joint, set by the leader"):
        as_batch(tree, {**values, "right_finger_joint": 0.3})


# ---------------------------------------------------------------------- limits
def test_limit_tolerance_is_between_the_probes():
    assert 1e-13 < LIMIT_TOLERANCE < 1e-9


def test_limit_violations_with_tolerance(planar):
    lo, hi = planar.lower_limits, planar.upper_limits
    assert hi.tolist() == [3.14159, 3.14159] and lo.tolist() == [-3.14159, -3.14159]
    Q = np.array([
        [hi[0], lo[1]],  # exactly at the limits
        [hi[0] + 1e-13, lo[1] - 1e-13],  # within the tolerance
        [hi[0] + 1e-9, 0.0],  # beyond
        [0.0, lo[1] - 1e-9],
        [0.0, 0.0],
        [-10.0, 10.0],
    ])
    expected = np.array([[False, False], [False, False], [True, False], [False, True], [False, False], [True, True]])
    mask = limit_violations(planar, Q)
    assert mask.dtype == bool and mask.shape == (6, 2)
    np.testing.assert_array_equal(mask, expected)
    assert out_of_limits(planar, Q) == [[], [], ["q1"], ["q2"], [], ["q1", "q2"]]


def test_unlimited_joints_never_violate(tree):
    Q = np.zeros((2, 5))
    Q[0, tree.q_index["right_shoulder"]] = 1e5  # continuous: no limits
    Q[1, tree.q_index["right_slide_joint"]] = 0.3 + 1e-6  # prismatic, upper limit 0.3
    assert out_of_limits(tree, Q) == [[], ["right_slide_joint"]]


def test_require_within_limits(planar):
    require_within_limits(planar, np.array([[0.0, 0.0], [3.14159 + 1e-13, -3.14159]]))  # no error
    Q = np.array([[0.0, 0.0], [0.0, 3.2], [4.0, 4.0]])
    with pytest.raises(LimitError) as err:
        require_within_limits(planar, Q)
    message = str(err.value)
    assert "configuration 1" in message
    assert "'q2'" in message and "3.2" in message
    assert "3.14159" in message
    assert "more" not in message
    with pytest.raises(LimitError, match=r"configuration 0: joint 'q1'.*\(and 1 more\)"):
        require_within_limits(planar, Q[2:])


def test_a_plain_list_of_numbers_reads_as_the_checked_way_does(catalogue):
    """A list of Python floats and ints (a JSON body's q) takes a short way: the same array as the
    checked reading of a sequence, and every bad value is still refused with the joint named."""
    from kinematics.model.joint_values import _from_seq

    model = catalogue.get("ur5")
    for q in ([0.1, -0.5, 0.8, 0.0, 1.2, -0.3], [0, 1, 2, 3, -4, 5], [1e-300, -0.0, 3, 0.5, 1e3, -7]):
        Q, batch = as_batch(model, q)
        assert not batch and Q.shape == (1, 6) and Q.tobytes() == _from_seq(model, q, "")[None].tobytes()
    for bad, match in (([0.0] * 5 + [True], "not a number"), ([0.0] * 5 + [10 ** 400], "joint"),
                       ([0.0] * 5 + [float("nan")], "not finite"), ([0.0] * 5, "expected 6")):
        with pytest.raises(JointValueError, match=match):
            as_batch(model, bad)
