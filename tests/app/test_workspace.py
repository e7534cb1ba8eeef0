"""POST /models/{id}/workspace: the JSON summary, the cloud as .npz / .npy, budgets (413) and bad input."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest

from kinematics import api, default_catalogue

PROBLEM = "application/problem+json"


def test_summary_json(api_client):
    r = api_client.post("/models/ur5/workspace", json={"link": "tool0", "samples": 20000, "random_seed": 2})
    assert r.status_code == 200, r.text
    body = r.json()
    ws = api.workspace(default_catalogue().get("ur5"), "tool0", samples=20000, random_seed=2)
    assert body["link"] == "tool0" and body["samples"] == 20000 and body["dimension"] == 3
    assert body["bounding_box"]["min"] == ws.bounding_box[0].tolist()
    assert body["bounding_box"]["max"] == ws.bounding_box[1].tolist()
    assert body["reach"] == ws.reach and body["volume"] == ws.volume and "area" not in body
    assert body["convergence"] == [{"samples": n, "volume": v} for n, v in ws.convergence]
    assert body["converged"] == ws.converged and body["advice"] == ws.advice
    assert body["voxel"] == ws.voxel and body["cell"] == ws.cell.tolist()
    assert body["occupied_voxels"] == len(ws.voxel_centers)
    assert body["manipulability"]["max"] == ws.manipulability.max()


def test_planar_area_and_defaults(api_client):
    r = api_client.post("/models/planar_2r/workspace", json={})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["link"] == "tool" and body["samples"] == 100000 and body["dimension"] == 2
    assert body["volume"] == 0.0
    assert body["area"] == pytest.approx(math.pi * (0.9**2 - 0.1**2), rel=0.01)
    assert set(body["convergence"][0]) == {"samples", "area"}
    assert api_client.post("/models/planar_2r/workspace").status_code == 200  # no body at all


def test_cloud_as_npz_and_npy(api_client):
    r = api_client.post("/models/ur5/workspace", json={"link": "tool0", "samples": 5000, "point": [0, 0, 0.1]},
                        headers={"Accept": "application/x-npz"})
    assert r.status_code == 200 and r.headers["content-type"] == "application/x-npz"
    z = np.load(io.BytesIO(r.content), allow_pickle=False)
    ws = api.workspace(default_catalogue().get("ur5"), "tool0", samples=5000, point=[0, 0, 0.1])
    np.testing.assert_array_equal(z["points"], ws.points)
    np.testing.assert_array_equal(z["manipulability"], ws.manipulability)
    np.testing.assert_array_equal(z["voxel_centers"], ws.voxel_centers)
    np.testing.assert_array_equal(z["voxel_manipulability"], ws.voxel_manipulability)
    assert z["reach"].shape == () and float(z["reach"]) == ws.reach
    assert z["convergence"].shape == (3, 2)
    r = api_client.post("/models/ur5/workspace", json={"samples": 3000}, headers={"Accept": "application/x-npy"})
    assert r.status_code == 200 and r.headers["x-columns"] == "x,y,z,manipulability"
    cloud = np.load(io.BytesIO(r.content))
    assert cloud.shape == (3000, 4)


def test_budgets_are_413(make_client):
    client = make_client(max_workspace_samples=10000, max_result_values=4 * 5000)
    r = client.post("/models/ur5/workspace", json={"samples": 10001})
    assert r.status_code == 413 and r.json()["type"].endswith("workspace-samples-too-large")
    assert r.json()["limit"] == 10000
    assert client.post("/models/ur5/workspace", json={"samples": 10000}).status_code == 200
    r = client.post("/models/ur5/workspace", json={"samples": 6000}, headers={"Accept": "application/x-npz"})
    assert r.status_code == 413 and r.json()["type"].endswith("result-too-large")
    assert client.post("/models/ur5/workspace", json={"samples": 5000},
                       headers={"Accept": "application/x-npz"}).status_code == 200


@pytest.mark.parametrize("body, status, fragment", [
    ({"link": "nope"}, 404, "nope"),
    ({"samples": 0}, 422, "samples"),
    ({"voxel": 0}, 422, "voxel"),
    ({"voxel": 1e-9, "samples": 100}, 422, "larger voxel"),
    ({"measure": "speed"}, 422, "measure"),
    ({"point": [0, 0]}, 422, "point"),
    ({"unknown": 1}, 422, "unknown"),
])
def test_bad_requests(api_client, body, status, fragment):
    r = api_client.post("/models/ur5/workspace", json=body)
    assert r.status_code == status, r.text
    assert r.headers["content-type"].startswith(PROBLEM)
    assert fragment in r.text


def test_openapi_documents_workspace(api_client):
    spec = api_client.get("/openapi.json").json()
    op = spec["paths"]["/models/{model_id}/workspace"]["post"]
    assert "application/x-npz" in op["responses"]["200"]["content"]
    assert "WorkspaceRequest" in spec["components"]["schemas"]


def test_a_voxel_too_fine_for_the_samples_says_so_instead_of_answering_zero(api_client):
    """The request that answered volume 0.0 (convergence 0 / 0 / 0) beside 135,762 occupied cells."""
    r = api_client.post("/models/ur5/workspace", json={"link": "tool0", "samples": 200000, "random_seed": 7,
                                                       "voxel": 0.02})
    assert r.status_code == 200, r.text
    body = r.json()
    occupied = body["occupied_voxels"] * math.prod(body["cell"])
    assert body["occupied_voxels"] > 100_000
    assert body["volume"] >= occupied > 1.0
    assert all(step["volume"] > 0 for step in body["convergence"])
    assert body["converged"] is False
    assert "too sparse" in body["advice"] and "larger voxels" in body["advice"] and "more samples" in body["advice"]
    coarse = api_client.post("/models/panda/workspace", json={"link": "panda_hand", "samples": 200000,
                                                              "random_seed": 7, "voxel": 0.1}).json()
    assert coarse["converged"] is True and coarse["advice"] is None
    assert 0 < coarse["volume"] < coarse["occupied_voxels"] * math.prod(coarse["cell"])  # the boundary layer removed


@pytest.mark.parametrize("model_id, link", [("ur5", "tool0"), ("panda", "panda_hand"), ("puma560_standard", None),
                                            ("ur5_dh", None)])
def test_fine_voxels_on_several_arms_answer_what_the_samples_show(api_client, model_id, link):
    body = {"samples": 50000, "random_seed": 3, "voxel": 0.015} | ({"link": link} if link else {})
    r = api_client.post(f"/models/{model_id}/workspace", json=body)
    assert r.status_code == 200, r.text
    answer = r.json()
    occupied = answer["occupied_voxels"] * math.prod(answer["cell"])
    assert answer["volume"] == pytest.approx(occupied, rel=1e-12) and answer["volume"] > 0
    assert [s["volume"] for s in answer["convergence"]] == sorted(s["volume"] for s in answer["convergence"])
    assert answer["converged"] is False and "too sparse" in answer["advice"]
