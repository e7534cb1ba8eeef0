"""kinematics.client for every operation beyond FK, Jacobians, velocity and one IK solution:
every IK solution, the family, Cartesian paths, calibration, collision, workspace, closed forms
and task vectors, each against the library's own answer on a live server (tests/live.py)."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import api, compile_model
from kinematics.algorithms.calibration.synthetic import experiment
from kinematics.client import Client, ServiceError
from kinematics.usecases import calibration_poses
from tests.live import LiveServer


@pytest.fixture(scope="module")
def kin(tmp_path_factory):
    data = tmp_path_factory.mktemp("client-ops-data")
    with LiveServer(data, data.parent / "client-ops-uvicorn.log") as live:
        yield Client(live.url)


def test_every_ik_solution_and_the_family(kin, ur5):
    Q = ur5.sample_configurations(3, np.random.default_rng(7))
    T = compile_model(ur5).fk(Q, ["tool0"])[:, 0]
    got = kin.ik_all("ur5", T, link="tool0")
    want = api.ik_all(ur5, T, link="tool0")
    assert kin.last_headers["x-family"] == want.family
    np.testing.assert_array_equal(got["count"], want.count)
    np.testing.assert_array_equal(got["q"], want.q)
    assert got["q"].shape[::2] == (3, 6) and got["count"].min() >= 8 and got["within_limits"].dtype == bool
    # one of them is the configuration the target came from
    for n in range(3):
        k = got["count"][n]
        assert np.min(np.abs(np.angle(np.exp(1j * (got["q"][n, :k] - Q[n])))).max(axis=1)) < 1e-8
    family = kin.ik_family("ur5", link="tool0")
    assert family == api.ik_family(ur5, link="tool0") and family["closed_form"] is True
    locked = kin.ik_family("ur5", link="tool0", locked={"shoulder_pan_joint": 0.3})
    assert locked["locked"] == {"shoulder_pan_joint": 0.3}


def test_cartesian_path(kin, ur5):
    q0 = np.array([0.1, -1.2, 1.4, -1.6, -1.5, 0.2])
    T0 = compile_model(ur5).fk(q0[None], ["tool0"])[0, 0]
    T1 = T0.copy()
    T1[:3, 3] += [0.0, 0.1, 0.05]
    got = kin.ik_path("ur5", np.stack([T0, T1]), link="tool0", seed=q0, step={"position": 0.01})
    want = api.ik_path(ur5, np.stack([T0, T1]), link="tool0", seed=q0, step={"position": 0.01})
    assert got["complete"] and got["fraction"] == 1.0
    assert isinstance(got["q"], np.ndarray) and got["q"].shape == want.q.shape
    np.testing.assert_allclose(got["q"], want.q, atol=1e-12)
    np.testing.assert_allclose(got["targets"][-1], T1, atol=1e-12)


def test_calibration(kin, ur5):
    poses = kin.calibration_poses("ur5", 8, link="tool0", random_seed=3)
    want = calibration_poses(ur5, 8, link="tool0", random_seed=3)
    assert poses["q"].shape == (8, 6)
    np.testing.assert_allclose(poses["q"], want.q, atol=1e-12)
    assert poses["measure"]["log_det"] == pytest.approx(want.log_det, rel=1e-12)
    _, Q, P = experiment(ur5, "tool0", "position", 40, np.random.default_rng(11), 20e-6)
    records = [{"q": q, "position": p} for q, p in zip(Q, P)]
    out = kin.calibrate("ur5", records, link="tool0")
    assert out["model"].startswith("u-") and out["rmse_after"] < 1e-4 < out["rmse_before"]
    assert out["residuals"]["after"].shape == (40,)
    csv = "\n".join([",".join(ur5.joint_names) + ",x,y,z"] + [",".join(repr(float(v)) for v in [*q, *p]) for q, p in zip(Q, P)])
    from_csv = kin.calibrate("ur5", link="tool0", csv=csv)
    assert from_csv["model"] == out["model"] and from_csv["rmse_after"] == pytest.approx(out["rmse_after"], rel=1e-9)
    # the calibrated model is a model of the service: FK of it predicts the measurements
    T = kin.fk(out["model"], Q[:5], links=["tool0"])
    assert T.shape == (5, 1, 4, 4)


def test_collision_and_matrix(kin, catalogue):
    panda = catalogue.get("panda")
    Q = np.array([[0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8, 0.02], [0.0] * 8])
    got = kin.collision("panda", Q, distance=True)
    want = api.collision(panda, Q, distance=True)
    np.testing.assert_array_equal(got["colliding"], want.colliding)
    assert got["colliding"].dtype == bool and got["checked_pairs"] == len(want.checked)
    np.testing.assert_allclose(got["min_distance"], want.min_distance, atol=1e-12)
    one = kin.collision("panda", Q[0])
    assert one["colliding"].shape == () and bool(one["colliding"]) == bool(want.colliding[0])
    matrix = kin.collision_matrix("panda")
    assert matrix["links"] and {d["reason"] for d in matrix["disabled"]} >= {"adjacent"}
    srdf = kin.collision_matrix("panda", format="srdf")
    assert srdf.lstrip().startswith("<") and "disable_collisions" in srdf


def test_workspace(kin, ur5):
    summary = kin.workspace("ur5", link="tool0", samples=2000, random_seed=1)
    want = api.workspace(ur5, link="tool0", samples=2000, random_seed=1)
    assert summary["reach"] == pytest.approx(want.reach, abs=1e-12)
    assert summary["volume"] == pytest.approx(want.volume, abs=1e-12)
    cloud = kin.workspace("ur5", link="tool0", samples=2000, random_seed=1, cloud=True)
    np.testing.assert_allclose(cloud["points"], want.points, atol=1e-12)
    assert cloud["manipulability"].shape == (2000,)


def test_closed_forms_and_task_vectors(kin, ur5):
    Q = ur5.sample_configurations(3, np.random.default_rng(5))
    got = kin.task("ur5", Q, link="tool0", representation="zyz")
    want = api.task(ur5, Q, link="tool0", representation="zyz")
    np.testing.assert_allclose(got["J_r"], want.J_r, atol=1e-12)
    np.testing.assert_allclose(got["r"], want.r, atol=1e-12)
    assert got["components"] == list(want.representation.labels)
    one = kin.task("ur5", Q[0], link="tool0", representation="position")
    assert one["r"].shape == (3,) and one["J_r"].shape == (3, 6)
    forms = kin.symbolic("planar_2r", what=["transforms"], format="text")
    assert [v["symbol"] for v in forms["joint_variables"]] == ["q1", "q2"] and forms["T"]
    dh = kin.symbolic_dh({"convention": "standard", "joints": [
        {"type": "revolute", "a": "a1", "alpha": 0, "d": 0, "theta": 0},
        {"type": "revolute", "a": "a2", "alpha": 0, "d": 0, "theta": 0}]}, format="text")
    assert dh.get("model") is None and set(dh["parameters"]) == {"a1", "a2"}
    with pytest.raises(ServiceError) as err:
        kin.task("ur5", Q, link="no-such-link")
    assert err.value.slug == "unknown-link"


def test_trajectory(kin, ur5):
    from kinematics import TrajectoryLimits, trajectory

    W = np.array([[0.0, -1.57, 1.57, 0.0, 1.57, 0.0], [0.5, -1.2, 1.2, 0.3, 1.57, 0.0], [1.0, -1.0, 0.8, 0.0, 1.2, 0.5]])
    got = kin.trajectory("ur5", W, limits={"velocity": 1.0, "acceleration": 3.0}, rate=50)
    want = trajectory(ur5, W, TrajectoryLimits(velocity=1.0, acceleration=3.0), rate=50)
    assert got["duration"] == want.duration and got["method"] == want.method
    for key in ("t", "q", "qd", "qdd"):
        assert isinstance(got[key], np.ndarray)
        np.testing.assert_array_equal(got[key], getattr(want, key))
    np.testing.assert_array_equal(got["limits"]["acceleration"], np.full(6, 3.0))
    binary = kin.trajectory("ur5", W, limits={"velocity": 1.0, "acceleration": 3.0}, rate=50, npz=True)
    assert binary["duration"] == want.duration and binary["method"] == want.method
    assert kin.joint_names() == list(ur5.joint_names)
    for key in ("t", "q", "qd", "qdd"):
        np.testing.assert_array_equal(binary[key], getattr(want, key))
    with pytest.raises(ServiceError) as err:
        kin.trajectory("ur5", W, limits={"velocity": 1.0})
    assert err.value.status == 422 and "acceleration" in err.value.detail
