"""REST API: binary batch transport (NumPy .npy in and out) and its refusals."""

from __future__ import annotations

import io
from urllib.parse import unquote

import numpy as np
import pytest

from kinematics import compile_model
from tests.helpers import PINOCCHIO_TOL, npy_bytes

NPY = "application/x-npy"
PROBLEM = "application/problem+json"


def load(body: bytes) -> np.ndarray:
    return np.load(io.BytesIO(body), allow_pickle=False)


@pytest.fixture(scope="module")
def Q(ur5):
    return ur5.sample_configurations(50, np.random.default_rng(11))


def test_fk_npy_round_trip(api_client, ur5, Q):
    r = api_client.post("/models/ur5/fk", params={"links": "all"}, content=npy_bytes(Q),
                        headers={"content-type": NPY, "accept": NPY})
    assert r.status_code == 200 and r.headers["content-type"] == NPY
    T = load(r.content)
    assert T.shape == (50, len(ur5.links), 4, 4) and T.dtype == np.float64
    links = [unquote(n) for n in r.headers["x-links"].split(",")]
    assert links == list(ur5.links)
    assert [unquote(n) for n in r.headers["x-joint-names"].split(",")] == list(ur5.joint_names)
    np.testing.assert_array_equal(T, compile_model(ur5).fk(Q, links))


def test_fk_npy_links_verify_and_json_answer(api_client, ur5, Q):
    r = api_client.post("/models/ur5/fk?links=tool0&links=forearm_link&verify=true", content=npy_bytes(Q[:5]),
                        headers={"content-type": NPY, "accept": NPY})
    assert r.status_code == 200
    assert r.headers["x-links"] == "tool0,forearm_link"
    assert float(r.headers["x-max-position-error"]) < PINOCCHIO_TOL
    assert load(r.content).shape == (5, 2, 4, 4)
    # comma-separated links, .npy in, JSON out (format from the query)
    j = api_client.post("/models/ur5/fk?links=tool0,forearm_link&format=matrix", content=npy_bytes(Q[:5]),
                        headers={"content-type": NPY})
    assert j.status_code == 200 and j.headers["content-type"] == "application/json"
    np.testing.assert_array_equal(np.array([p["tool0"] for p in j.json()["poses"]]), load(r.content)[:, 0])
    # JSON in, .npy out
    k = api_client.post("/models/ur5/fk", json={"q": Q[:5].tolist(), "links": ["tool0", "forearm_link"]},
                        headers={"accept": NPY})
    np.testing.assert_array_equal(load(k.content), load(r.content))
    # one configuration as a (dof,) array
    one = api_client.post("/models/ur5/fk?links=tool0", content=npy_bytes(Q[0]), headers={"content-type": NPY, "accept": NPY})
    assert load(one.content).shape == (1, 1, 4, 4)
    # float32 and integer arrays are accepted and widened
    f32 = api_client.post("/models/ur5/fk?links=tool0", content=npy_bytes(np.zeros((2, 6), np.float32)),
                          headers={"content-type": NPY, "accept": NPY})
    assert f32.status_code == 200 and load(f32.content).shape == (2, 1, 4, 4)


def test_jacobian_npy_round_trip(api_client, ur5, Q):
    r = api_client.post("/models/ur5/jacobian?link=tool0&reference=local", content=npy_bytes(Q),
                        headers={"content-type": NPY, "accept": NPY})
    assert r.status_code == 200
    J = load(r.content)
    assert J.shape == (50, 6, 6)
    assert r.headers["x-link"] == "tool0" and r.headers["x-reference"] == "local"
    np.testing.assert_array_equal(J, compile_model(ur5).jacobian(Q, "tool0", "local"))


def test_npy_limits_refuse_and_report(api_client):
    Q = np.zeros((3, 6))
    Q[2, 2] = 4.0
    r = api_client.post("/models/ur5/fk?limits=refuse", content=npy_bytes(Q), headers={"content-type": NPY, "accept": NPY})
    assert r.status_code == 422 and r.json()["joint"] == "elbow_joint"
    r = api_client.post("/models/ur5/fk", content=npy_bytes(Q), headers={"content-type": NPY, "accept": NPY})
    assert r.status_code == 200 and r.headers["x-out-of-limits"] == "1"


@pytest.mark.parametrize("body, status, needle", [
    (npy_bytes(np.array([[object()] * 6], dtype=object)), 422, "object"),
    (b"not an npy file at all", 400, "magic"),
    (b"PK\x03\x04 zip (npz) header", 400, "magic"),
    (npy_bytes(np.zeros((2, 6)))[:-8], 400, "malformed"),
    (npy_bytes(np.zeros((2, 5))), 422, "expected 6"),
    (npy_bytes(np.zeros((2, 6, 1))), 422, "shape"),
    (npy_bytes(np.zeros((2, 6), dtype=complex)), 422, "dtype"),
    (npy_bytes(np.zeros((2, 6), dtype=bool)), 422, "dtype"),
    (npy_bytes(np.array(["a"] * 6)), 422, "dtype"),
    (npy_bytes(np.zeros(2, dtype=[("a", "f8"), ("b", "f8")])), 422, "dtype"),
    (npy_bytes(np.array([[0, 0, np.nan, 0, 0, 0]])), 422, "elbow_joint"),
    (npy_bytes(np.zeros((0, 6))), 422, "no configuration"),
])
def test_npy_refusals(api_client, body, status, needle):
    for path in ("/models/ur5/fk", "/models/ur5/jacobian"):
        r = api_client.post(path, content=body, headers={"content-type": NPY, "accept": NPY})
        assert r.status_code == status, (path, r.text)
        assert r.headers["content-type"] == PROBLEM and needle in r.json()["detail"]


def test_npy_batch_limit(make_client):
    c = make_client(max_batch=10)
    r = c.post("/models/ur5/fk", content=npy_bytes(np.zeros((11, 6))), headers={"content-type": NPY})
    assert r.status_code == 413 and r.json()["field"] == "q"


def test_names_header_escapes_commas():
    from app.npy import names_header

    assert names_header(["a,b", "c d", "tool0"]) == "a%2Cb,c%20d,tool0"
    assert [unquote(n) for n in names_header(["a,b", "ü"]).split(",")] == ["a,b", "ü"]
