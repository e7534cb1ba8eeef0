"""Heavy requests: the time budget (KIN_REQUEST_TIMEOUT) answers a problem naming it; light
requests are not affected; the settings are read from the environment."""

from __future__ import annotations

import numpy as np

from kinematics import api
from kinematics.io.catalogue import default_catalogue

PROBLEM = "application/problem+json"


def _unreachable(n):
    model = default_catalogue().get("ur5")
    T = api.fk(model, model.sample_configurations(n, np.random.default_rng(0)), links=["tool0"]).poses[:, 0]
    T[:, :3, 3] *= 3.0
    return T.tolist()


def test_a_request_over_its_time_budget_answers_503_naming_the_budget(make_client):
    client = make_client(request_timeout=0.05)
    r = client.post("/models/ur5/ik", json={"target": _unreachable(400), "link": "tool0", "restarts": 1000})
    assert r.status_code == 503, r.text
    assert r.headers["content-type"].startswith(PROBLEM)
    body = r.json()
    assert body["type"] == "urn:kinematics:problem:time-budget-exceeded"
    assert body["setting"] == "KIN_REQUEST_TIMEOUT" and body["limit"] == 0.05
    assert "KIN_REQUEST_TIMEOUT" in body["detail"] and "0.05 s" in body["detail"]
    r = client.post("/models/ur5/workspace", json={"samples": 1_000_000})
    assert r.status_code == 503 and r.json()["type"].endswith("time-budget-exceeded"), r.text
    # light requests do not go through the budget; small heavy ones fit in it
    assert client.get("/health").status_code == 200
    assert client.post("/models/ur5/fk", json={"q": [0.0] * 6}).status_code == 200
    assert client.post("/models/planar_2r/ik", json={"target": [[[1, 0, 0, 0.5], [0, 1, 0, 0.4], [0, 0, 1, 0],
                                                                   [0, 0, 0, 1]]] * 2,
                                                      "mode": "position"}).status_code == 200


def test_large_json_batches_go_through_the_heavy_path(make_client):
    from app import heavy

    client = make_client()
    before = heavy.STATS["started"]
    Q = default_catalogue().get("ur5").sample_configurations(5000, np.random.default_rng(0))
    r = client.post("/models/ur5/fk", json={"q": Q.tolist(), "links": ["tool0"], "format": "matrix"})
    assert r.status_code == 200
    np.testing.assert_array_equal(np.array([p["tool0"] for p in r.json()["poses"]]),
                                  api.fk(default_catalogue().get("ur5"), Q, links=["tool0"]).poses[:, 0])
    assert heavy.STATS["started"] >= before + 2  # the body's parsing and the FK


def test_settings_from_the_environment(monkeypatch):
    from app.settings import Settings

    for name, value in (("KIN_REQUEST_TIMEOUT", "7.5"), ("KIN_MAX_HEAVY_JOBS", "3"), ("KIN_HEAVY_NICE", "0"),
                        ("KIN_SHUTDOWN_TIMEOUT", "12")):
        monkeypatch.setenv(name, value)
    s = Settings()
    assert (s.request_timeout, s.max_heavy_jobs, s.heavy_nice, s.shutdown_timeout) == (7.5, 3, 0, 12.0)


def test_large_json_bodies_decoded_in_the_decoder_process_give_the_same_answers(make_client):
    ur5 = default_catalogue().get("ur5")
    Q = ur5.sample_configurations(3000, np.random.default_rng(2))
    T = api.fk(ur5, Q[:500], links=["tool0"]).poses[:, 0]
    requests = [("/models/ur5/fk", {"q": Q.tolist(), "links": "all"}),
                ("/models/ur5/jacobian", {"q": Q.tolist(), "reference": "local"}),
                ("/models/ur5/velocity", {"q": Q.tolist(), "qdot": Q.tolist()}),
                ("/models/ur5/ik", {"target": T.tolist(), "link": "tool0"}),
                # invalid: the same problem whoever decodes it
                ("/models/ur5/fk", {"q": Q.tolist()[:-1] + [[0.1] * 5 + ["x"]]}),
                ("/models/ur5/ik", {"target": T.tolist(), "link": "tool0", "restarts": -1})]
    here, there = make_client(decode_process_bytes=0), make_client(decode_process_bytes=1)
    for path, body in requests:
        a, b = here.post(path, json=body), there.post(path, json=body)
        assert a.status_code == b.status_code and a.status_code in (200, 422), (path, a.text[:300])
        assert a.content == b.content or a.status_code == 422 and {**a.json(), "request_id": 0} == \
            {**b.json(), "request_id": 0}, path


def test_one_ik_target_with_many_steps_is_heavy_work_under_the_budget(make_client):
    """One target with 10,001 attempts may take seconds: not on the event loop, and under the budget."""
    client = make_client(request_timeout=0.05)
    target = [[1, 0, 0, 5.0], [0, 1, 0, 5.0], [0, 0, 1, 5.0], [0, 0, 0, 1]]  # 8.7 m away: out of reach
    r = client.post("/models/ur5/ik", json={"target": target, "link": "tool0", "restarts": 10_000})
    assert r.status_code == 503 and r.json()["type"].endswith("time-budget-exceeded"), r.text
    r = client.post("/models/ur5/ik", json={"target": target, "link": "tool0"})  # the default work: inline
    assert r.status_code == 200 and r.json()["success"] is False


def test_long_answers_are_encoded_in_slices_to_the_same_bytes():
    import orjson

    from app import responses

    ur5 = default_catalogue().get("ur5")
    Q = ur5.sample_configurations(3 * responses.CHUNK_ITEMS + 5, np.random.default_rng(3))
    fk = api.fk(ur5, Q, links=["tool0", "wrist_1_link"])
    J = api.jacobian(ur5, Q)
    from kinematics.io.pose_records import pose_output

    for content in ({"poses": pose_output(fk.poses, fk.links, fmt, True), "out_of_limits": fk.out_of_limits(),
                     "verification": None} for fmt in ("pose", "matrix", "compact")):
        assert responses.dumps(content) == orjson.dumps(content, option=responses._ORJSON_OPTIONS,
                                                        default=responses._default)
    content = {"jacobian": J.jacobians, "nan": np.full(5000, np.nan), 7: [1] * 5000, "empty": []}
    assert responses.dumps(content) == orjson.dumps(content, option=responses._ORJSON_OPTIONS,
                                                    default=responses._default)
    assert len(responses.dump_parts(content)) > 4 and len(responses.dump_parts({"a": [1] * 10})) == 1


def test_a_worker_runs_blas_on_one_thread(make_client):
    """KIN_BLAS_THREADS (default 1): OpenBLAS's threads spin between calls, and one per core kept the
    cores busy during calibrations while the event loop waited for one (app.heavy.limit_blas_threads)."""
    from threadpoolctl import threadpool_info

    make_client()
    blas = [p for p in threadpool_info() if p["user_api"] == "blas"]
    assert blas and all(p["num_threads"] == 1 for p in blas), blas
