"""POST /models/{id}/trajectory: the answer's samples (limits at every sample and between them by
finite differences of the returned q, at rest at both ends, on the spline), .npz, and every bad input
answered with a problem naming it."""

from __future__ import annotations

import io

import numpy as np
import pytest

PROBLEM = "application/problem+json"
NPZ = "application/x-npz"
W = [[0.0, -1.57, 1.57, 0.0, 1.57, 0.0], [0.5, -1.2, 1.2, 0.3, 1.57, 0.0], [1.0, -1.0, 0.8, 0.0, 1.2, 0.5]]
BODY = {"waypoints": W, "limits": {"acceleration": 3.0}, "rate": 1000}
SLACK = 1e-7


def post(client, body, **headers):
    return client.post("/models/ur5/trajectory", json=body, headers=headers)


def check_samples(body, v, a):
    t, q, qd, qdd = (np.array(body[k]) for k in ("t", "q", "qd", "qdd"))
    assert t[0] == 0 and t[-1] == body["duration"] and np.all(np.diff(t) > 0)
    assert np.max(np.abs(qd) / v) <= 1 + SLACK and np.max(np.abs(qdd) / a) <= 1 + SLACK
    h = t[1] - t[0]
    uniform = q[:-1]  # the last step may be shorter
    assert np.max(np.abs(np.diff(uniform, axis=0)) / h / v) <= 1 + SLACK
    assert np.max(np.abs(np.diff(uniform, 2, axis=0)) / h**2 / a) <= 1 + SLACK
    assert np.abs(qd[[0, -1]]).max() < 1e-6
    np.testing.assert_allclose(q[[0, -1]], np.array(W)[[0, -1]], atol=1e-9)
    return t, q, qd, qdd


def test_spline_trajectory(api_client, ur5):
    r = post(api_client, BODY)
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["joint_names"] == list(ur5.joint_names) and body["interpolation"] == "spline"
    v = np.array(body["limits"]["velocity"])
    np.testing.assert_array_equal(v, [j.limits.velocity for j in ur5.moving_joints])  # the URDF's
    assert body["limits"]["acceleration"] == [3.0] * 6
    t, q, qd, qdd = check_samples(body, v, 3.0)
    scipy_interpolate = pytest.importorskip("scipy.interpolate")
    spline = scipy_interpolate.CubicSpline(np.linspace(0, 1, 3), W)
    # every sample lies on the spline: for joint 0 (monotone along it) find s, then compare every joint
    s = np.linspace(0, 1, 200001)
    q0 = spline(s)[:, 0]
    assert np.all(np.diff(q0) > 0)
    s_at = np.interp(q[:, 0], q0, s)
    np.testing.assert_allclose(spline(s_at), q, atol=1e-6)
    assert max(np.abs(qdd).max() / 3.0, np.max(np.abs(qd) / v)) > 0.999  # a limit is reached


def test_npz_answer(api_client):
    r = post(api_client, BODY, accept=NPZ)
    assert r.status_code == 200 and r.headers["content-type"].startswith(NPZ)
    arrays = np.load(io.BytesIO(r.content))
    assert set(arrays.files) == {"t", "q", "qd", "qdd", "duration"} and arrays["duration"].shape == ()
    body = post(api_client, BODY).json()
    np.testing.assert_array_equal(arrays["q"], body["q"])
    assert float(arrays["duration"]) == body["duration"]
    assert r.headers["x-joint-names"].split(",")[0] == "shoulder_pan_joint"


def test_jerk_limited_linear_with_tool_speed(api_client):
    limits = {"velocity": 1.0, "acceleration": 3.0, "jerk": 30.0, "tool_speed": {"link": "tool0", "max": 0.4}}
    r = post(api_client, {**BODY, "interpolation": "linear", "blend": 0.1, "limits": limits})
    assert r.status_code == 200, r.text
    body = r.json()
    t, q, qd, qdd = check_samples(body, 1.0, 3.0)
    h = t[1] - t[0]
    assert np.max(np.abs(np.diff(q[:-1], 3, axis=0)) / h**3 / 30.0) <= 1 + SLACK
    assert np.abs(qdd[[0, -1]]).max() < 1e-9
    assert body["optimal_duration"] < body["duration"]
    assert body["limits"]["jerk"] == [30.0] * 6 and body["limits"]["tool_speed"]["link"] == "tool0"


@pytest.mark.parametrize("body, status, words", [
    ({**BODY, "waypoints": [W[0]]}, 422, "at least 2"),
    ({**BODY, "waypoints": [W[0], W[1][:5]]}, 422, "waypoints"),
    ({**BODY, "limits": {}}, 422, "acceleration is required"),
    ({**BODY, "limits": {"acceleration": 0}}, 422, "positive"),
    ({**BODY, "limits": {"acceleration": -1.0}}, 422, "positive"),
    ({**BODY, "limits": {"acceleration": 1.0, "velocity": [1.0, 2.0]}}, 422, "one per joint"),
    ({**BODY, "limits": {"acceleration": 1.0, "jerk": 0.0}}, 422, "jerk"),
    ({**BODY, "limits": {"acceleration": 1.0, "tool_speed": {"link": "nope", "max": 1.0}}}, 404, "nope"),
    ({**BODY, "limits": {"acceleration": 1.0, "tool_speed": {"link": "tool0", "max": 0.0}}}, 422, "tool_speed"),
    ({**BODY, "rate": 0}, 422, "rate"),
    ({**BODY, "rate": 200_000}, 413, "trajectory_max_rate"),
    ({**BODY, "waypoints": [W[0], [7.0] + W[1][1:]]}, 422, "shoulder_pan_joint"),
    ({**BODY, "waypoints": [[0.0] * 6, [6.2] + [0.0] * 5, [6.2] + [0.0] * 5, [0.0] * 6]}, 422, "spline between"),
    ({**BODY, "interpolation": "cubic"}, 422, ""),
    ({**BODY, "blend": -1.0}, 422, "blend"),
])
def test_bad_input(api_client, body, status, words):
    r = post(api_client, body)
    assert r.status_code == status, r.text
    assert r.headers["content-type"].startswith(PROBLEM)
    assert words in r.text


def test_nan_waypoint(api_client):
    r = api_client.post("/models/ur5/trajectory", headers={"content-type": "application/json"},
                        content=b'{"waypoints": [[NaN, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0]], "limits": {"acceleration": 1}}')
    assert r.status_code == 422 and r.headers["content-type"].startswith(PROBLEM)


def test_model_without_velocity_limits_asks_for_them(api_client):
    r = api_client.post("/models/double_pendulum_continuous/trajectory",
                        json={"waypoints": [[0.0, 0.0], [0.5, 0.5]], "limits": {"acceleration": 1.0}})
    assert r.status_code == 422 and "give limits.velocity" in r.json()["detail"]
    r = api_client.post("/models/double_pendulum_continuous/trajectory",
                        json={"waypoints": [[0.0, 0.0], [0.5, 0.5]], "limits": {"acceleration": 1.0, "velocity": 1.0}})
    assert r.status_code == 200


def test_too_many_samples_413(make_client):
    client = make_client(trajectory_max_samples=100)
    r = post(client, BODY)
    assert r.status_code == 413 and "trajectory_max_samples" in r.json()["detail"]


def test_planning_over_the_time_budget_503(make_client):
    client = make_client(request_timeout=0.05)
    rng = np.random.default_rng(0)
    waypoints = np.cumsum(rng.uniform(-0.01, 0.01, (2000, 6)), axis=0).tolist()
    r = post(client, {"waypoints": waypoints, "interpolation": "linear", "blend": 0.005,
                      "limits": {"acceleration": 2.0, "jerk": 20.0}, "rate": 10})
    assert r.status_code == 503, r.text[:300]
    assert r.json()["type"].endswith("time-budget-exceeded")


@pytest.mark.parametrize("jerk", [None, 30.0])
def test_tool_speed_held_judged_from_fk_of_the_returned_q(api_client, ur5, jerk):
    from kinematics import fk

    limits = {"acceleration": 3.0, "jerk": jerk, "tool_speed": {"link": "tool0", "max": 0.3}}
    body = post(api_client, {**BODY, "limits": limits}).json()
    q = np.array(body["q"])[:-1]
    p = fk(ur5, q, links=["tool0"]).poses[:, 0, :3, 3]
    speed = np.linalg.norm(np.diff(p, axis=0), axis=1) * BODY["rate"]
    assert speed.max() <= 0.3 * (1 + SLACK)
    assert speed.max() > 0.29  # the tool speed is what limits this path


def test_seven_joint_arm_from_an_ik_path_answer(api_client):
    # end to end: a Panda's Cartesian path solved by /ik/path, its rows timed jerk-limited
    from kinematics.engine.poe import compile_model
    from kinematics.io import default_catalogue

    panda = default_catalogue().get("panda")
    q0 = [0.1, -0.4, 0.2, -2.0, 0.3, 1.5, 0.7, 0.02]
    T0 = compile_model(panda).fk(np.atleast_2d(q0), ["panda_link8"])[0, 0]
    T1 = T0.copy()
    T1[:3, 3] += [0.1, -0.05, 0.08]
    r = api_client.post("/models/panda/ik/path", json={"link": "panda_link8", "waypoints": [T0.tolist(), T1.tolist()],
                                                        "seed": q0, "step": {"position": 0.02}})
    assert r.status_code == 200, r.text
    path = r.json()
    assert path["complete"] and len(path["q"][0]) == 8 and len(path["q"]) >= 5  # 7 arm joints and the finger
    limits = {"velocity": 1.0, "acceleration": 3.0, "jerk": 30.0}
    r = api_client.post("/models/panda/trajectory", json={"waypoints": path["q"], "limits": limits, "rate": 1000})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["joint_names"] == path["joint_names"] and body["duration"] > body["optimal_duration"]
    t, q, qd, qdd = (np.array(body[k]) for k in ("t", "q", "qd", "qdd"))
    np.testing.assert_allclose(q[[0, -1]], np.array(path["q"])[[0, -1]], atol=1e-9)
    h = t[1] - t[0]
    for k, limit in enumerate((1.0, 3.0, 30.0), start=1):
        assert np.max(np.abs(np.diff(q[:-1], k, axis=0))) / h**k <= limit * (1 + SLACK)
    assert np.max(np.abs(qd)) <= 1 + SLACK and np.max(np.abs(qdd)) <= 3 * (1 + SLACK)
    assert np.abs(qdd[[0, -1]]).max() < 1e-9 and np.abs(qd[[0, -1]]).max() < 1e-9
