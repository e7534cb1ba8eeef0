"""Bad and oversized input is a 4xx naming the problem, never a 500 or a 503 (issue: bounded operations).

- A chain with no joint left to move (every joint of the chain locked, or a link with no joint on the
  way) is one 422 on every IK operation: every solution, one solution, .npy targets, the family, the path.
"""

from __future__ import annotations

import io

import numpy as np
import pytest

from kinematics import compile_model, default_catalogue

PROBLEM = "application/problem+json"
UR5_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
              "wrist_3_joint")
LOCKED_ALL = {name: 0.0 for name in UR5_JOINTS}


def _tool0(q):
    return compile_model(default_catalogue().get("ur5")).fk(np.atleast_2d(np.asarray(q, float)), ["tool0"])[:, 0]


def _nothing_to_solve(r, link="tool0"):
    assert r.status_code == 422, r.text
    assert r.headers["content-type"] == PROBLEM
    detail = r.json()["detail"]
    assert link in detail and "nothing left to solve" in detail


@pytest.mark.parametrize("solutions", ["all", "one"])
def test_every_joint_locked_is_422_on_ik(api_client, solutions):
    T = _tool0([0.0] * 6)[0]
    r = api_client.post("/models/ur5/ik", json={"link": "tool0", "target": T.tolist(), "solutions": solutions,
                                                 "locked": LOCKED_ALL})
    _nothing_to_solve(r)
    assert "every joint of the chain" in r.json()["detail"]


def test_every_joint_locked_is_422_on_npy_ik(api_client):
    buf = io.BytesIO()
    np.save(buf, _tool0([0.0] * 6))
    locked = "&".join(f"locked={name}:0" for name in UR5_JOINTS)
    for solutions in ("all", "one"):
        r = api_client.post(f"/models/ur5/ik?link=tool0&solutions={solutions}&{locked}", content=buf.getvalue(),
                            headers={"Content-Type": "application/x-npy", "Accept": "application/x-npz"})
        _nothing_to_solve(r)


def test_every_joint_locked_is_422_on_family_and_path(api_client):
    locked = "&".join(f"locked={name}:0" for name in UR5_JOINTS)
    _nothing_to_solve(api_client.get(f"/models/ur5/ik/family?link=tool0&{locked}"))
    T = _tool0([0.0] * 6)[0]
    r = api_client.post("/models/ur5/ik/path", json={"link": "tool0", "waypoints": [T.tolist(), T.tolist()],
                                                      "seed": [0.0] * 6, "locked": LOCKED_ALL})
    _nothing_to_solve(r)


def test_a_link_with_no_joint_on_its_chain_is_422(api_client):
    r = api_client.post("/models/ur5/ik", json={"link": "base_link", "target": np.eye(4).tolist(), "solutions": "all"})
    _nothing_to_solve(r, "base_link")
    assert "has no joint" in r.json()["detail"]
    _nothing_to_solve(api_client.get("/models/ur5/ik/family?link=base_link"), "base_link")


# ---------------------------------------------------------------------- client-chosen times and sizes
@pytest.mark.parametrize("timeout", [5e-324, 0.0, -1.0, 1e9])
def test_a_symbolic_timeout_out_of_its_range_is_422(api_client, timeout):
    r = api_client.post("/symbolic/dh", json={"table": {"joints": [{"type": "revolute", "a": "a1"}]},
                                              "timeout": timeout})
    assert r.status_code == 422, r.text
    assert r.json()["field"] == "timeout"


@pytest.mark.parametrize("value, named", [(b"NaN", "NaN"), (b"Infinity", "Infinity"), (b"-Infinity", "-Infinity")])
def test_a_non_finite_margin_is_422_naming_it(api_client, value, named):
    body = b'{"q": [0, 0, 0, 0, 0, 0], "margin": ' + value + b"}"
    r = api_client.post("/models/ur5/collision", content=body, headers={"Content-Type": "application/json"})
    assert r.status_code == 422, r.text
    assert r.json()["field"] == "margin" and named in r.json()["detail"] and "finite" in r.json()["detail"]
    assert "less than" not in r.json()["detail"]


def test_a_non_finite_symbolic_timeout_is_422_naming_it(api_client):
    body = b'{"table": {"joints": [{"type": "revolute", "a": "a1"}]}, "timeout": NaN}'
    r = api_client.post("/symbolic/dh", content=body, headers={"Content-Type": "application/json"})
    assert r.status_code == 422 and "NaN" in r.json()["detail"], r.text


def test_the_requests_own_timeout_running_out_is_a_4xx_not_a_5xx():
    from app.errors import kinematics_problem
    from kinematics.errors import SymbolicTimeoutError

    mine = kinematics_problem(SymbolicTimeoutError("over", timeout=0.1, setting="timeout"))
    theirs = kinematics_problem(SymbolicTimeoutError("over", timeout=30, setting="KIN_SYMBOLIC_TIMEOUT"))
    assert (mine.status_code, theirs.status_code) == (422, 503)


# ---------------------------------------------------------------------- sizes checked before the work
def _refuse_calls(monkeypatch, module, name):
    def refuse(*args, **kwargs):
        raise AssertionError(f"{name} ran: the request should have been refused before the work")

    monkeypatch.setattr(module, name, refuse)


def _too_large(r, budget, field, limit):
    assert r.status_code == 413, r.text
    body = r.json()
    assert r.headers["content-type"] == PROBLEM
    assert body["type"].endswith(f"{budget}-too-large") and body["field"] == field and body["limit"] == limit
    assert str(limit) in body["detail"]
    return body


def test_every_solution_ik_is_refused_by_the_most_it_could_list(make_client, monkeypatch):
    from kinematics.algorithms import ik_all as algorithm

    client = make_client(max_ik_solutions=300)  # a UR5 target: up to 8 x 2^5 with the +-2 pi copies of 5 joints
    T = _tool0([[0.3, -1.0, 1.2, -0.5, 0.8, 0.2]] * 2)
    r = client.post("/models/ur5/ik", json={"link": "tool0", "target": T[:1].tolist(), "solutions": "all"})
    assert r.status_code == 200 and len(r.json()["solutions"][0]) == r.json()["count"][0] > 8, r.text
    _refuse_calls(monkeypatch, algorithm, "all_solutions")
    body = _too_large(client.post("/models/ur5/ik", json={"link": "tool0", "target": T.tolist(), "solutions": "all"}),
                      "ik-solutions", "target", 300)
    assert "512" in body["detail"] and "max_ik_solutions" in body["detail"]
    buf = io.BytesIO()
    np.save(buf, T)
    r = client.post("/models/ur5/ik?link=tool0&solutions=all", content=buf.getvalue(),
                    headers={"Content-Type": "application/x-npy", "Accept": "application/x-npz"})
    _too_large(r, "ik-solutions", "target", 300)


def test_a_cartesian_path_is_refused_by_its_target_count(make_client, monkeypatch):
    from kinematics.algorithms import ik_path as algorithm

    client = make_client(max_ik_solutions=256 * 20)  # 20 targets of the UR5's every in-limit solution
    T0 = _tool0([0.3, -1.0, 1.2, -0.5, 0.8, 0.2])[0]
    T1 = T0.copy()
    T1[:3, 3] += [0.0, 0.0, 0.5]
    body = {"link": "tool0", "waypoints": [T0.tolist(), T1.tolist()], "seed": [0.3, -1.0, 1.2, -0.5, 0.8, 0.2]}
    _refuse_calls(monkeypatch, algorithm, "cartesian_path")
    r = client.post("/models/ur5/ik/path", json={**body, "step": {"position": 1e-5}})  # 50,001 targets
    assert "50001 targets" in _too_large(r, "ik-solutions", "target", 256 * 20)["detail"]


def test_calibration_measurements_are_counted_before_they_are_read(make_client, monkeypatch):
    from kinematics.usecases import calibration as usecase

    client = make_client(max_measurements=3)
    m = {"q": [0.0] * 6, "position": [0.1, 0.2, 0.3]}
    _refuse_calls(monkeypatch, usecase, "joint_batch")
    r = client.post("/models/ur5/calibrate", json={"link": "tool0", "measurements": [m] * 4})
    _too_large(r, "measurements", "measurements", 3)
    _refuse_calls(monkeypatch, usecase, "parse_measurements_csv")
    header = ",".join(UR5_JOINTS) + ",x,y,z\n"
    csv = header + "0,0,0,0,0,0,0.1,0.2,0.3\n" * 4
    r = client.post("/models/ur5/calibrate?link=tool0", content=csv, headers={"Content-Type": "text/csv"})
    _too_large(r, "measurements", "measurements", 3)


def test_a_mesh_over_the_triangle_cap_is_refused_from_its_bytes_before_it_is_parsed(monkeypatch):
    import trimesh

    from kinematics.algorithms import collision
    from kinematics.io.collision_geometry import Shape

    monkeypatch.setattr(collision, "MAX_MESH_TRIANGLES", 10)
    _refuse_calls(monkeypatch, trimesh, "load")
    vertices = "".join(f"v {i} {i % 2} {i % 3}\n" for i in range(14))
    obj = (vertices + "".join(f"f {i + 1} {i + 2} {i + 3}\n" for i in range(11))).encode()
    stl = bytes(80) + (11).to_bytes(4, "little") + bytes(50 * 11)
    ascii_stl = b"solid x\n" + b"facet normal 0 0 1\n outer loop\n endloop\nendfacet\n" * 11 + b"endsolid x\n"
    for fmt, data in (("obj", obj), ("stl", stl), ("stl", ascii_stl)):
        assert collision._triangles_at_least(data, fmt) == 11
        with pytest.raises(collision.CollisionGeometryError, match="at least 11 triangles; the limit is 10"):
            collision._mesh_from_bytes(Shape(kind="mesh", origin=np.eye(4), size=(1.0, 1.0, 1.0),
                                             source="m." + fmt, data=data, format=fmt))


def test_the_decode_of_a_large_body_and_the_work_share_one_time_budget(make_client, monkeypatch):
    """The budget KIN_REQUEST_TIMEOUT counts from the decode of a large body: the work that follows
    gets the same token, not a fresh budget."""
    from app import heavy

    tokens = []
    call = heavy._call

    def recording(token, state, fn, args):
        tokens.append(token)
        return call(token, state, fn, args)

    monkeypatch.setattr(heavy, "_call", recording)
    client = make_client(decode_process_bytes=0)  # over INLINE_BODY_BYTES: decoded as heavy work, here
    Q = np.zeros((3000, 6)).tolist()
    r = client.post("/models/ur5/fk", json={"q": Q, "links": ["tool0"]})
    assert r.status_code == 200, r.text
    assert len(tokens) == 2 and tokens[0] is tokens[1]
    r = client.post("/models/ur5/fk", json={"q": Q, "links": ["tool0"]})
    assert len(tokens) == 4 and tokens[2] is tokens[3] and tokens[2] is not tokens[0]  # one per request


# ---------------------------------------------------------------------- checked during the work
def test_a_large_answer_and_a_collision_batch_stop_when_their_request_is_cancelled(ur5):
    from app.adapter import checked
    from app.responses import CHUNK_ITEMS, dump_parts
    from kinematics import api
    from kinematics.algorithms import self_collision
    from kinematics.errors import CancelledError

    content = {"q": list(range(3 * CHUNK_ITEMS))}
    token = api.Cancellation()
    token.cancel("the client disconnected")
    with api.cancellable(token):
        with pytest.raises(CancelledError):
            dump_parts(content)
        with pytest.raises(CancelledError):
            list(checked(range(10)))
        with pytest.raises(CancelledError):
            self_collision.check(ur5, np.zeros((3, 6)), pairs=[("shoulder_link", "forearm_link")])
    assert b"".join(dump_parts(content)).startswith(b'{"q":[0,1,2') and list(checked(range(3))) == [0, 1, 2]


# ---------------------------------------------------------------------- large JSON counted before its decode
def test_a_large_json_batch_is_refused_by_its_count_before_it_is_decoded(make_client, monkeypatch):
    """A body over INLINE_BODY_BYTES (64 KiB; smaller ones are decoded at once) whose batch is over its
    limit is refused (413 naming the field and the limit) from its items counted in the raw bytes:
    nothing decodes it (a decode of 10^5 IK targets took gigabytes), in the worker or in its decoder
    process."""
    from app import heavy
    from pydantic import BaseModel

    decoded = []
    validate = BaseModel.model_validate_json.__func__

    def recording(cls, data, *args, **kwargs):
        decoded.append((cls.__name__, len(data)))
        return validate(cls, data, *args, **kwargs)

    monkeypatch.setattr(BaseModel, "model_validate_json", classmethod(recording))
    client = make_client(decode_process_bytes=0, max_batch=1000, max_measurements=1000)
    T = _tool0([0.3, -1.0, 1.2, -0.5, 0.8, 0.2])[0].tolist()
    for path, body, field, limit in (
            ("/models/ur5/ik", {"link": "tool0", "target": [T] * 1001}, "target", 1000),
            ("/models/ur5/fk", {"q": [[0.1] * 6] * 5000, "links": ["tool0"]}, "q", 1000),
            ("/models/ur5/collision", {"q": [[0.1] * 6] * 5000}, "q", 1000),
            ("/models/ur5/calibrate", {"link": "tool0", "measurements": [
                {"q": [0.1] * 6, "position": [0.1, 0.2, 0.3]}] * 1500}, "measurements", 1000)):
        r = client.post(path, json=body)
        b = _too_large(r, "batch" if field != "measurements" else "measurements", field, limit)
        assert "counted in the body before decoding it" in b["detail"], b
    assert decoded == []
    # at the limit: decoded and answered as before (one target is one item, not its four rows)
    r = client.post("/models/ur5/ik", json={"link": "tool0", "target": [T] * 1000})
    assert r.status_code == 200, r.text
    assert decoded and decoded[-1][0] == "IKRequest"
    r = client.post("/models/ur5/fk", json={"q": [0.1] * 6, "links": ["tool0"], "pad": " " * 70_000})
    assert r.status_code == 422 and decoded[-1][0] == "FKRequest"  # a large body with one q: decoded, its field named


def test_the_count_of_a_json_bodys_items_matches_its_decode(monkeypatch):
    """:func:`app.json_count.top_level_counts` against ``json.loads`` on bodies with strings holding
    brackets, commas, escaped quotes and backslashes, nested values and whitespace, read in chunks of
    a few bytes (so that every structure and escape straddles a chunk's end)."""
    import json
    import random

    from app import json_count

    rnd = random.Random(4)
    tricky = ['a"b', "c\\", "[", "]", ",", "{", "}", ':"', '\\"', "\\\\", "x" * 30]

    def value(depth):
        kind = rnd.randrange(6 if depth < 3 else 3)
        if kind == 0:
            return rnd.uniform(-1e3, 1e3)
        if kind == 1:
            return rnd.choice(tricky) + rnd.choice(tricky)
        if kind == 2:
            return rnd.randrange(-5, 5)
        if kind == 3:
            return {rnd.choice(tricky): value(depth + 1) for _ in range(rnd.randrange(3))}
        return [value(depth + 1) for _ in range(rnd.randrange(5))]

    for chunk in (3, 7, 64, 1 << 20):
        monkeypatch.setattr(json_count, "CHUNK_BYTES", chunk)
        for _ in range(60):
            doc = {k: value(0) for k in rnd.sample(["q", "target", "measurements", "links", 'k"q', "x"], 4)}
            doc["q" if rnd.random() < 0.5 else 'k"q'] = [value(1) for _ in range(rnd.randrange(8))]
            text = json.dumps(doc, indent=rnd.choice([None, 1])).encode()
            got = json_count.top_level_counts(text, ("q", "target", "measurements", 'k"q'))
            want = {k: len(v) for k, v in doc.items() if isinstance(v, list) and k != "links" and k != "x"}
            assert {k: n for k, (n, _) in got.items()} == want, (chunk, text)
