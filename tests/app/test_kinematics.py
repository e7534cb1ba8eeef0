"""REST API: forward kinematics and Jacobians in JSON (single, batch, name maps, formats, limits, verify)."""

from __future__ import annotations

import io

import numpy as np
import pytest

from kinematics import compile_model
from kinematics.algorithms.measures import conditioning
from kinematics.spatial.transforms import pose_components
from kinematics.verify.pinocchio import PINOCCHIO_VERSION, reference_for
from tests.helpers import PINOCCHIO_TOL

#: our PoE vs Pinocchio (docs/design.md quality bar)
#: JSON round trip of float64 (orjson writes the shortest repr, which reads back exactly)
EXACT = 0.0
PROBLEM = "application/problem+json"


@pytest.fixture(scope="module")
def ur5_q(ur5):
    return ur5.sample_configurations(4, np.random.default_rng(7))


def test_fk_single_equals_library_and_pinocchio(api_client, ur5, ur5_q):
    q = ur5_q[0]
    r = api_client.post("/models/ur5/fk", json={"q": q.tolist(), "links": "all", "verify": True})
    assert r.status_code == 200
    body = r.json()
    assert body["model"] == "ur5" and body["joint_names"] == list(ur5.joint_names)
    assert body["links"] == list(ur5.links) and body["format"] == "pose"
    T = compile_model(ur5).fk(q[None, :], list(ur5.links))[0]
    theirs = reference_for(ur5).poses(q)
    for k, link in enumerate(ur5.links):
        pose = body["poses"][link]
        np.testing.assert_allclose(pose["matrix"], T[k], atol=EXACT)
        np.testing.assert_allclose(pose["matrix"], theirs[link], atol=PINOCCHIO_TOL)
        comps = pose_components(T[k])
        np.testing.assert_allclose(pose["position"], comps["position"], atol=EXACT)
        quat = pose["quaternion"]
        np.testing.assert_allclose([quat["w"], quat["x"], quat["y"], quat["z"]], comps["quaternion"], atol=EXACT)
        np.testing.assert_allclose(pose["rpy"], comps["rpy"], atol=EXACT)
    ver = body["verification"]
    assert ver["reference"] == f"pinocchio {PINOCCHIO_VERSION}"
    assert 0 <= ver["max_position_error"] < PINOCCHIO_TOL and 0 <= ver["max_rotation_error"] < PINOCCHIO_TOL
    assert body["out_of_limits"] == []


def test_fk_default_links_are_leaf_links_and_names_select(api_client, ur5, ur5_q):
    q = ur5_q[1].tolist()
    body = api_client.post("/models/ur5/fk", json={"q": q}).json()
    assert body["links"] == list(ur5.leaf_links) and list(body["poses"]) == list(ur5.leaf_links)
    assert body["verification"] is None
    some = ["forearm_link", "tool0"]
    body = api_client.post("/models/ur5/fk", json={"q": q, "links": some}).json()
    assert list(body["poses"]) == some
    T = compile_model(ur5).fk(np.array([q]), some)[0]
    np.testing.assert_allclose(body["poses"]["forearm_link"]["matrix"], T[0], atol=EXACT)
    # a link named twice is answered once (JSON and .npy alike)
    body = api_client.post("/models/ur5/fk", json={"q": q, "links": ["tool0", "forearm_link", "tool0"]}).json()
    assert body["links"] == ["tool0", "forearm_link"]
    buf = io.BytesIO()
    np.save(buf, np.array([q, q]))
    r = api_client.post("/models/ur5/fk?links=tool0,tool0", content=buf.getvalue(),
                        headers={"content-type": "application/x-npy", "accept": "application/x-npy"})
    assert r.status_code == 200 and np.load(io.BytesIO(r.content)).shape == (2, 1, 4, 4)


def test_fk_batch_equals_singles_and_name_map_equals_vector(api_client, ur5, ur5_q):
    batch = api_client.post("/models/ur5/fk", json={"q": ur5_q.tolist(), "links": ["tool0"], "verify": True}).json()
    assert isinstance(batch["poses"], list) and len(batch["poses"]) == len(ur5_q)
    assert isinstance(batch["out_of_limits"], list) and len(batch["out_of_limits"]) == len(ur5_q)
    assert batch["verification"]["max_position_error"] < PINOCCHIO_TOL
    for n, q in enumerate(ur5_q):
        single = api_client.post("/models/ur5/fk", json={"q": q.tolist(), "links": ["tool0"]}).json()
        assert single["poses"] == batch["poses"][n]
        as_map = {name: float(v) for name, v in zip(ur5.joint_names, q)}
        by_name = api_client.post("/models/ur5/fk", json={"q": as_map, "links": ["tool0"]}).json()
        assert by_name["poses"] == single["poses"]
    # a batch of name maps
    maps = [{name: float(v) for name, v in zip(ur5.joint_names, q)} for q in ur5_q]
    assert api_client.post("/models/ur5/fk", json={"q": maps, "links": ["tool0"]}).json()["poses"] == batch["poses"]


def test_fk_formats_matrix_and_compact(api_client, ur5, ur5_q):
    links = ["wrist_1_link", "tool0"]
    T = compile_model(ur5).fk(ur5_q, links)
    m = api_client.post("/models/ur5/fk", json={"q": ur5_q.tolist(), "links": links, "format": "matrix"}).json()
    assert m["format"] == "matrix"
    np.testing.assert_allclose(np.array([[p[l] for l in links] for p in m["poses"]]), T, atol=EXACT)
    single = api_client.post("/models/ur5/fk", json={"q": ur5_q[0].tolist(), "links": links, "format": "matrix"}).json()
    np.testing.assert_allclose(single["poses"]["tool0"], T[0, 1], atol=EXACT)
    c = api_client.post("/models/ur5/fk", json={"q": ur5_q.tolist(), "links": links, "format": "compact"}).json()
    comps = pose_components(T)
    for k, link in enumerate(links):
        np.testing.assert_allclose(c["poses"][link]["positions"], comps["position"][:, k], atol=EXACT)
        np.testing.assert_allclose(c["poses"][link]["quaternions"], comps["quaternion"][:, k], atol=EXACT)
    # compact is always (N, ...) arrays, N = 1 for one configuration
    one = api_client.post("/models/ur5/fk", json={"q": ur5_q[0].tolist(), "format": "compact", "links": ["tool0"]}).json()
    assert np.shape(one["poses"]["tool0"]["positions"]) == (1, 3)
    assert np.shape(one["poses"]["tool0"]["quaternions"]) == (1, 4)


def test_fk_out_of_limits_report_and_refuse(api_client, ur5):
    q = [0.0] * 6
    q[2] = 4.0  # elbow_joint limits are +-pi
    body = api_client.post("/models/ur5/fk", json={"q": q}).json()
    assert body["out_of_limits"] == ["elbow_joint"]
    batch = api_client.post("/models/ur5/fk", json={"q": [[0.0] * 6, q]}).json()
    assert batch["out_of_limits"] == [[], ["elbow_joint"]]
    r = api_client.post("/models/ur5/fk", json={"q": [[0.0] * 6, q], "limits": "refuse"})
    assert r.status_code == 422 and r.headers["content-type"] == PROBLEM
    assert r.json()["joint"] == "elbow_joint" and "configuration 1" in r.json()["detail"]
    assert api_client.post("/models/ur5/fk", json={"q": [0.0] * 6, "limits": "refuse"}).status_code == 200


@pytest.mark.parametrize("q, needle", [
    ([0.0] * 5, "expected 6 joint values"),
    ([[0.0] * 6, [0.0] * 5], "configuration 1"),
    ({"shoulder_pan_joint": 0.0}, "missing"),
    ({"nope": 0.0}, "unknown joint"),
    ([0, 0, 0, 0, 0, "1"], "q.5"),
    ([0, 0, 0, 0, 0, True], "q.5"),
    ([1, [2]], "q"),
    ([], "expected 6"),
    ("abc", "q"),
])
def test_fk_bad_q_is_422_naming_it(api_client, q, needle):
    r = api_client.post("/models/ur5/fk", json={"q": q})
    assert r.status_code == 422, r.text
    assert r.headers["content-type"] == PROBLEM and needle in r.json()["detail"]


def test_fk_non_finite_q_is_422_naming_the_joint(api_client):
    r = api_client.post("/models/ur5/fk", content=b'{"q": [0, 0, NaN, 0, 0, 0]}',
                        headers={"content-type": "application/json"})
    assert r.status_code == 422 and r.json()["joint"] == "elbow_joint"
    r = api_client.post("/models/ur5/fk", content=b'{"q": [[0, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0, Infinity]]}',
                        headers={"content-type": "application/json"})
    assert r.status_code == 422 and r.json()["joint"] == "wrist_3_joint" and "configuration 1" in r.json()["detail"]


def test_fk_unknown_link_and_model_are_404(api_client):
    r = api_client.post("/models/ur5/fk", json={"q": [0.0] * 6, "links": ["nope"]})
    assert r.status_code == 404 and r.json()["link"] == "nope" and r.json()["model"] == "ur5"
    r = api_client.post("/models/no_such_robot/fk", json={"q": [0.0] * 6})
    assert r.status_code == 404 and r.json()["model"] == "no_such_robot"
    r = api_client.post("/models/ur5/fk", json={"q": [0.0] * 6, "link": "tool0"})  # a Jacobian field on FK
    assert r.status_code == 422 and r.json()["field"] == "link"


def test_fk_mimic_tree_and_zero_dof(api_client, catalogue):
    # Talos: a tree with mimic grippers; every link checked against Pinocchio by the service
    talos = catalogue.get("talos_reduced")
    Q = talos.sample_configurations(2, np.random.default_rng(3))
    r = api_client.post("/models/talos_reduced/fk", json={"q": Q.tolist(), "links": "all", "verify": True,
                                                          "format": "matrix"})
    assert r.status_code == 200
    ver = r.json()["verification"]
    assert ver["max_position_error"] < PINOCCHIO_TOL and ver["max_rotation_error"] < PINOCCHIO_TOL
    np.testing.assert_allclose(r.json()["poses"][1][talos.links[-1]], compile_model(talos).fk(Q, [talos.links[-1]])[1, 0],
                               atol=EXACT)
    fixed = '<robot name="rigid"><link name="a"/><link name="b"/><joint name="j" type="fixed"><parent link="a"/>' \
            '<child link="b"/><origin xyz="1 2 3"/></joint></robot>'
    mid = api_client.post("/models", content=fixed, headers={"content-type": "application/xml"}).json()["id"]
    body = api_client.post(f"/models/{mid}/fk", json={"q": []}).json()
    assert body["poses"]["b"]["position"] == [1.0, 2.0, 3.0]
    jac = api_client.post(f"/models/{mid}/jacobian", json={"q": []}).json()
    assert jac["jacobian"] == [[], [], [], [], [], []] and jac["manipulability"] == 1.0


@pytest.mark.parametrize("reference", ["world", "local", "local_world_aligned"])
def test_jacobian_references_measures_and_verify(api_client, ur5, ur5_q, reference):
    q = ur5_q[2]
    r = api_client.post("/models/ur5/jacobian", json={"q": q.tolist(), "link": "tool0", "reference": reference,
                                                     "verify": True})
    assert r.status_code == 200
    body = r.json()
    J = compile_model(ur5).jacobian(q[None, :], "tool0", reference)
    np.testing.assert_allclose(body["jacobian"], J[0], atol=EXACT)
    np.testing.assert_allclose(body["jacobian"], reference_for(ur5).jacobian(q, "tool0", reference), atol=PINOCCHIO_TOL)
    assert body["reference"] == reference and body["link"] == "tool0" and body["joint_names"] == list(ur5.joint_names)
    m = conditioning(J)
    np.testing.assert_allclose(body["singular_values"], m["singular_values"][0], atol=EXACT)
    assert body["manipulability"] == pytest.approx(float(m["manipulability"][0]), abs=0)
    assert body["condition_number"] == pytest.approx(float(m["condition_number"][0]), abs=0)
    assert body["verification"]["max_jacobian_error"] < PINOCCHIO_TOL


def test_jacobian_batch_default_link_and_singularity(api_client, ur5, ur5_q):
    body = api_client.post("/models/ur5/jacobian", json={"q": ur5_q.tolist()}).json()
    assert body["link"] == ur5.leaf_links[0] and body["reference"] == "world"
    J = compile_model(ur5).jacobian(ur5_q, ur5.leaf_links[0], "world")
    assert np.shape(body["jacobian"]) == (len(ur5_q), 6, 6)
    np.testing.assert_allclose(body["jacobian"], J, atol=EXACT)
    assert len(body["manipulability"]) == len(ur5_q) and len(body["out_of_limits"]) == len(ur5_q)
    # q = 0 is a UR5 singularity (wrist aligned): condition number infinite -> null, manipulability ~0
    home = api_client.post("/models/ur5/jacobian", json={"q": [0.0] * 6, "link": "tool0"}).json()
    assert home["condition_number"] is None and home["manipulability"] < 1e-9


def test_jacobian_errors(api_client):
    r = api_client.post("/models/ur5/jacobian", json={"q": [0.0] * 6, "reference": "body"})
    assert r.status_code == 422 and r.json()["field"] == "reference"
    r = api_client.post("/models/ur5/jacobian", json={"q": [0.0] * 6, "link": "nope"})
    assert r.status_code == 404 and r.json()["link"] == "nope"
    r = api_client.post("/models/ur5/jacobian", json={"q": [0.0] * 6, "links": ["tool0"]})
    assert r.status_code == 422 and r.json()["field"] == "links"


def test_batch_and_verify_limits_are_413(make_client):
    c = make_client(max_batch=3, max_verify=2, max_result_values=16 * 5)
    Q = np.zeros((4, 6)).tolist()
    r = c.post("/models/ur5/fk", json={"q": Q})
    assert r.status_code == 413 and r.json()["field"] == "q" and r.headers["content-type"] == PROBLEM
    r = c.post("/models/ur5/fk", json={"q": Q[:3], "verify": True, "links": ["tool0"]})
    assert r.status_code == 413 and r.json()["field"] == "verify"
    r = c.post("/models/ur5/fk", json={"q": Q[:3], "links": ["tool0", "base_link"]})  # 3 x 2 x 16 > 80 numbers
    assert r.status_code == 413
    assert c.post("/models/ur5/fk", json={"q": Q[:2], "links": ["tool0", "base_link"]}).status_code == 200


def test_verify_when_pinocchio_cannot_load_is_422(api_client, monkeypatch):
    import kinematics.verify.pinocchio as crosscheck
    from kinematics.errors import ReferenceUnavailableError

    def unavailable(*args, **kwargs):
        raise ReferenceUnavailableError("Pinocchio cannot load model 'ur5': simulated")

    monkeypatch.setattr(crosscheck, "compare_fk", unavailable)
    monkeypatch.setattr(crosscheck, "compare_jacobian", unavailable)
    for path in ("/models/ur5/fk", "/models/ur5/jacobian"):
        r = api_client.post(path, json={"q": [0.0] * 6, "verify": True})
        assert r.status_code == 422 and r.headers["content-type"] == PROBLEM
        assert "simulated" in r.json()["detail"]
        assert api_client.post(path, json={"q": [0.0] * 6}).status_code == 200  # without verify: fine


def test_base_pose_moves_the_world_frame(api_client, ur5, ur5_q):
    """`base` (T_world_root): poses and Jacobians equal the library's re-expression; verify still holds."""
    from kinematics.algorithms.base import jacobian_in_world, poses_in_world
    from kinematics.io.poses import base_poses

    base = {"xyz": [1.0, -2.0, 0.5], "rpy": [0.1, 0.2, 1.3]}
    Q = ur5_q[:3]
    body = api_client.post("/models/ur5/fk", json={"q": Q.tolist(), "links": ["tool0"], "base": base, "verify": True}).json()
    B = base_poses(base, len(Q))
    expected = poses_in_world(compile_model(ur5).fk(Q, ["tool0"]), B)
    np.testing.assert_allclose([p["tool0"]["matrix"] for p in body["poses"]], expected[:, 0], atol=EXACT)
    assert body["verification"]["max_position_error"] < 1e-9
    # a different pose per configuration
    per = [base, {"xyz": [0, 0, 0], "rpy": [0, 0, 0]}, base]
    body = api_client.post("/models/ur5/fk", json={"q": Q.tolist(), "links": ["tool0"], "base": per}).json()
    np.testing.assert_allclose(body["poses"][1]["tool0"]["matrix"], compile_model(ur5).fk(Q[1:2], ["tool0"])[0, 0], atol=EXACT)
    for reference in ("world", "local", "local_world_aligned"):
        r = api_client.post("/models/ur5/jacobian", json={"q": Q.tolist(), "link": "tool0", "reference": reference,
                                                        "base": base, "verify": True}).json()
        J = jacobian_in_world(compile_model(ur5).jacobian(Q, "tool0", reference), B, reference)
        np.testing.assert_allclose(r["jacobian"], J, atol=EXACT)
        assert r["verification"]["max_jacobian_error"] < 1e-9


@pytest.mark.parametrize("base,needle", [
    ([[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "base: not a rigid transform"),
    ({"position": [0, 0, 0], "quaternion": {"w": 0.5, "x": 0, "y": 0, "z": 0}}, "not a unit quaternion"),
    ([{"xyz": [0, 0, 0], "rpy": [0, 0, 0]}] * 2, "2 poses given for 1 configurations"),
])
def test_bad_base_pose_is_422_naming_it(api_client, base, needle):
    r = api_client.post("/models/ur5/fk", json={"q": [0.0] * 6, "base": base})
    assert r.status_code == 422 and r.headers["content-type"].startswith("application/problem+json")
    assert needle in r.json()["detail"]
    r = api_client.post("/models/ur5/fk", json={"q": [0.0] * 6, "base": {"xyz": [0, 0], "rpy": [0, 0, 0]}})
    assert r.status_code == 422  # pydantic or the library: either way a problem naming base
    assert "base" in r.text


def test_small_requests_on_the_loop_and_large_in_the_pool_answer_alike(api_client, ur5):
    """Requests of at most INLINE_MAX_CONFIGURATIONS configurations are answered on the event
    loop, larger ones in the thread pool: the same numbers and the same errors either way."""
    from app.routes.kinematics import INLINE_MAX_CONFIGURATIONS

    poe = compile_model(ur5)
    Q = ur5.sample_configurations(INLINE_MAX_CONFIGURATIONS + 1, np.random.default_rng(21))
    for rows in (Q[:INLINE_MAX_CONFIGURATIONS], Q):
        r = api_client.post("/models/ur5/fk", json={"q": rows.tolist(), "links": "all", "format": "matrix"})
        assert r.status_code == 200, r.text
        got = np.array([[c[link] for link in ur5.links] for c in r.json()["poses"]])
        np.testing.assert_allclose(got, poe.fk(rows), atol=1e-12, rtol=0)
        r = api_client.post("/models/ur5/jacobian", json={"q": rows.tolist(), "link": "tool0", "reference": "local"})
        assert r.status_code == 200, r.text
        np.testing.assert_allclose(np.array(r.json()["jacobian"]), poe.jacobian(rows, "tool0", "local"), atol=1e-12, rtol=0)
        r = api_client.post("/models/ur5/fk", json={"q": rows.tolist(), "links": ["no_such_link"]})
        assert r.status_code == 404 and "no_such_link" in r.json()["detail"]
