"""The pose output formats of an FK answer (kinematics.io.pose_records.pose_output)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from kinematics.io.pose_records import pose_output
from kinematics.spatial.rotations import rpy_to_matrix
from kinematics.spatial.transforms import make_transform, pose_components

LINKS = ["shoulder", "tool"]


@pytest.fixture
def poses(rng) -> np.ndarray:
    """(N=3, L=2, 4, 4) rigid poses."""
    T = np.zeros((3, 2, 4, 4))
    T[..., :3, :3] = Rotation.random(6, random_state=rng).as_matrix().reshape(3, 2, 3, 3)
    T[..., :3, 3] = rng.uniform(-1.0, 1.0, size=(3, 2, 3))
    T[..., 3, 3] = 1.0
    return T


def test_pose_format(poses):
    out = pose_output(poses, LINKS, "pose")
    comps = pose_components(poses)
    assert isinstance(out, list) and len(out) == 3
    for n, config in enumerate(out):
        assert list(config) == LINKS
        for k, link in enumerate(LINKS):
            rec = config[link]
            assert set(rec) == {"matrix", "position", "quaternion", "rpy"}
            np.testing.assert_array_equal(rec["matrix"], poses[n, k])
            np.testing.assert_array_equal(rec["position"], poses[n, k, :3, 3])
            np.testing.assert_array_equal(rec["position"], comps["position"][n, k])
            q = rec["quaternion"]
            assert list(q) == ["w", "x", "y", "z"]
            assert all(type(v) is float for v in q.values())
            assert [q["w"], q["x"], q["y"], q["z"]] == comps["quaternion"][n, k].tolist()
            assert q["w"] >= 0.0
            np.testing.assert_array_equal(rec["rpy"], comps["rpy"][n, k])
            np.testing.assert_allclose(rpy_to_matrix(rec["rpy"]), poses[n, k, :3, :3], atol=1e-12)


def test_pose_format_quaternion_keys_are_not_shuffled():
    """A quarter turn about z: w = z = sqrt(1/2), x = y = 0."""
    T = make_transform(rpy_to_matrix([0.0, 0.0, np.pi / 2]), [1.0, 2.0, 3.0])[None, None]
    rec = pose_output(T, ["tool"], "pose", is_batch=False)["tool"]
    assert rec["quaternion"] == pytest.approx({"w": np.sqrt(0.5), "x": 0.0, "y": 0.0, "z": np.sqrt(0.5)}, abs=1e-12)
    assert rec["position"].tolist() == [1.0, 2.0, 3.0]
    np.testing.assert_allclose(rec["rpy"], [0.0, 0.0, np.pi / 2], atol=1e-12)
    T = make_transform(rpy_to_matrix([np.pi / 2, 0.0, 0.0]), [0.0, 0.0, 0.0])[None, None]
    assert pose_output(T, ["tool"], is_batch=False)["tool"]["quaternion"] == pytest.approx(
        {"w": np.sqrt(0.5), "x": np.sqrt(0.5), "y": 0.0, "z": 0.0}, abs=1e-12)


def test_matrix_format(poses):
    out = pose_output(poses, LINKS, "matrix")
    assert isinstance(out, list) and len(out) == 3
    for n, config in enumerate(out):
        assert list(config) == LINKS
        for k, link in enumerate(LINKS):
            assert config[link].shape == (4, 4)
            np.testing.assert_array_equal(config[link], poses[n, k])


def test_compact_format(poses):
    out = pose_output(poses, LINKS, "compact")
    comps = pose_components(poses)
    assert isinstance(out, dict) and list(out) == LINKS
    for k, link in enumerate(LINKS):
        assert set(out[link]) == {"positions", "quaternions"}
        assert out[link]["positions"].shape == (3, 3)
        assert out[link]["quaternions"].shape == (3, 4)
        assert out[link]["positions"].flags.c_contiguous and out[link]["quaternions"].flags.c_contiguous
        np.testing.assert_array_equal(out[link]["positions"], poses[:, k, :3, 3])
        np.testing.assert_array_equal(out[link]["quaternions"], comps["quaternion"][:, k])
        assert np.all(out[link]["quaternions"][:, 0] >= 0.0)


@pytest.mark.parametrize("fmt", ["pose", "matrix"])
def test_single_configuration_is_one_map(poses, fmt):
    one = poses[1:2]
    single = pose_output(one, LINKS, fmt, is_batch=False)
    assert isinstance(single, dict) and list(single) == LINKS
    batch = pose_output(one, LINKS, fmt, is_batch=True)
    assert isinstance(batch, list) and len(batch) == 1
    for link in LINKS:
        np.testing.assert_array_equal(single[link]["matrix"] if fmt == "pose" else single[link], poses[1, LINKS.index(link)])
        if fmt == "pose":
            assert single[link]["quaternion"] == batch[0][link]["quaternion"]


def test_compact_single_configuration_keeps_the_per_link_arrays(poses):
    out = pose_output(poses[:1], LINKS, "compact", is_batch=False)
    assert out["tool"]["positions"].shape == (1, 3)
    assert out["tool"]["quaternions"].shape == (1, 4)
