"""POST /models/{id}/calibrate and /calibration/poses: a calibrated model is an ordinary model."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics.algorithms.calibration.synthetic import experiment

SIGMA = 20e-6


@pytest.fixture(scope="module")
def ur5_data():
    from kinematics import default_catalogue

    model = default_catalogue().get("ur5")
    rng = np.random.default_rng(11)
    return (model, *experiment(model, "tool0", "position", 60, rng, SIGMA))


def body(Q, P, **extra):
    return {"link": "tool0", "measurements": [{"q": q.tolist(), "position": p.tolist()} for q, p in zip(Q, P)], **extra}


def test_calibrate_registers_a_model_whose_fk_predicts_the_measurements(api_client, ur5_data):
    model, truth, Q, P = ur5_data
    r = api_client.post("/models/ur5/calibrate", json=body(Q, P, holdout=0.25))
    assert r.status_code == 201, r.text
    out = r.json()
    assert out["from"] == "ur5" and out["model"].startswith("u-") and r.headers["location"] == f"/models/{out['model']}"
    assert out["identifiable"] == 27 and len(out["parameters"]) == 27
    assert {"name", "reason"} <= set(out["unidentifiable"][0])
    assert out["rmse_before"] > 1e-3 and out["rmse_after"] < 2 * SIGMA * np.sqrt(3)
    assert len(out["holdout"]) == 15 and out["holdout_rmse"] < 2 * SIGMA * np.sqrt(3)
    assert len(out["residuals"]["before"]) == 60 and out["outliers"] == []
    # the calibrated model: its URDF, and FK with the returned base and point
    urdf = api_client.get(f"/models/{out['model']}/urdf")
    assert urdf.status_code == 200 and "<robot" in urdf.text
    fk = api_client.post(f"/models/{out['model']}/fk", json={
        "q": Q[:10].tolist(), "links": ["tool0"], "base": out["base"], "point": out["point"]})
    assert fk.status_code == 200, fk.text
    poses = fk.json()["poses"]
    got = np.array([p["tool0"]["position"] for p in poses])
    want = truth.predict(Q[:10])[:, :3, 3]
    assert np.abs(got - want).max() < 10 * SIGMA
    # every endpoint works on it: a Jacobian, and IK back to a pose of its own FK
    jac = api_client.post(f"/models/{out['model']}/jacobian", json={"q": Q[0].tolist(), "link": "tool0"})
    assert jac.status_code == 200, jac.text
    target = poses[0]["tool0"]
    ik = api_client.post(f"/models/{out['model']}/ik", json={
        "link": "tool0", "target": {"position": target["position"], "quaternion": target["quaternion"]},
        "base": out["base"], "point": out["point"]})
    assert ik.status_code == 200 and ik.json()["success"], ik.text


def test_calibrate_from_a_csv_upload(api_client, ur5_data):
    model, truth, Q, P = ur5_data
    lines = [",".join(model.joint_names) + ",x,y,z"] + [",".join(repr(float(v)) for v in [*q, *p]) for q, p in zip(Q, P)]
    r = api_client.post("/models/ur5/calibrate?link=tool0&loss=huber&holdout=0.2", content="\n".join(lines),
                        headers={"Content-Type": "text/csv"})
    assert r.status_code == 201, r.text
    assert r.json()["identifiable"] == 27 and len(r.json()["holdout"]) == 12


def test_calibrate_poses(api_client):
    from kinematics import default_catalogue

    model = default_catalogue().get("ur5")
    rng = np.random.default_rng(12)
    truth, Q, T = experiment(model, "tool0", "pose", 40, rng, SIGMA)
    meas = [{"q": q.tolist(), "pose": t.tolist()} for q, t in zip(Q, T)]
    r = api_client.post("/models/ur5/calibrate", json={"link": "tool0", "measurements": meas})
    assert r.status_code == 201, r.text
    out = r.json()
    assert out["identifiable"] == 30 and out["tool"] is not None and out["point"] is None
    fk = api_client.post(f"/models/{out['model']}/fk", json={"q": Q[:5].tolist(), "links": ["tool0"],
                                                             "base": out["base"], "tool": out["tool"]})
    got = np.array([p["tool0"]["position"] for p in fk.json()["poses"]])
    assert np.abs(got - truth.predict(Q[:5])[:, :3, 3]).max() < 10 * SIGMA


@pytest.mark.parametrize("change,status,word", [
    (lambda b: {**b, "measurements": b["measurements"][:5]}, 422, "equations"),
    (lambda b: {**b, "measurements": [{**m, "q": m["q"][:5]} for m in b["measurements"]]}, 422, "6"),
    (lambda b: {**b, "measurements": [{**m, "q": b["measurements"][0]["q"]} for m in b["measurements"]]}, 422,
     "same configuration"),
    (lambda b: {**b, "link": "tool9"}, 404, "tool9"),
])
def test_bad_input_is_4xx_naming_the_problem_and_registers_nothing(api_client, ur5_data, change, status, word):
    model, truth, Q, P = ur5_data
    before = len(api_client.get("/models").json())
    r = api_client.post("/models/ur5/calibrate", json=change(body(Q, P)))
    assert r.status_code == status, r.text
    assert word in r.json()["detail"]
    assert len(api_client.get("/models").json()) == before


def test_nan_in_a_csv_is_refused(api_client, ur5_data):
    model, truth, Q, P = ur5_data
    lines = [",".join(model.joint_names) + ",x,y,z"] + [",".join(repr(float(v)) for v in [*q, *p]) for q, p in zip(Q, P)]
    lines[4] = lines[4].replace(lines[4].split(",")[2], "nan", 1)
    r = api_client.post("/models/ur5/calibrate?link=tool0", content="\n".join(lines), headers={"Content-Type": "text/csv"})
    assert r.status_code == 422 and "non-finite" in r.json()["detail"], r.text


def test_calibration_poses(api_client):
    r = api_client.post("/models/ur5/calibration/poses", json={"link": "tool0", "n": 12, "random_seed": 3})
    assert r.status_code == 200, r.text
    out = r.json()
    assert np.array(out["q"]).shape == (12, 6)
    assert out["measure"]["log_det"] > out["measure"]["random_log_det"]
    assert out["measure"]["identifiable"] == 27


def test_calibrate_with_compliance_and_prior(api_client):
    """FIGAROH's TIAGo training session: the compliances are among the parameters; a bad option is a 422."""
    from bench.figaroh_tiago import FIXTURES, LINK, SESSIONS, read_session
    from kinematics import default_catalogue

    tiago = default_catalogue().get("tiago")
    Q, points = read_session(FIXTURES / SESSIONS[0][2], tiago)
    req = {"link": LINK, "measurements": [{"q": q.tolist(), "position": p.tolist()} for q, p in zip(Q, points[:, 0])],
           "compliance": {"joints": ["arm_2_joint", "arm_4_joint"]}, "prior": True}
    r = api_client.post("/models/tiago/calibrate", json=req)
    assert r.status_code == 201, r.text
    names = [p["name"] for p in r.json()["parameters"]]
    assert "arm_2_joint.compliance" in names and "arm_3_joint.compliance" not in names
    assert r.json()["rmse_after"] < 2e-3
    for bad, word in (({"prior": {"length": -1}}, "length"), ({"compliance": {"joints": ["head_1_joint"]}}, "head_1_joint")):
        r = api_client.post("/models/tiago/calibrate", json={**req, **bad})
        assert r.status_code == 422 and word in r.text, r.text
