"""kinematics.client against a live server (tests/live.py): numpy in and out, problem details."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import api, compile_model
from kinematics.client import Client, ServiceError
from tests.live import LiveServer
from tests.paths import FIXTURES

KEY = "client-test-key"


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    data = tmp_path_factory.mktemp("client-data")
    with LiveServer(data, data.parent / "client-uvicorn.log", env={"KIN_API_KEY": KEY}) as live:
        yield live


def test_fk_and_jacobian_equal_the_library(server, ur5):
    kin = Client(server.url)
    Q = ur5.sample_configurations(50, np.random.default_rng(1))
    T = kin.fk("ur5", Q, links=["tool0", "base_link"])
    assert T.shape == (50, 2, 4, 4) and kin.links() == ["tool0", "base_link"]
    np.testing.assert_array_equal(T, api.fk(ur5, Q, links=["tool0", "base_link"]).poses)
    assert kin.joint_names() == list(ur5.joint_names)
    T_all = kin.fk("ur5", Q[0], links="all")
    assert T_all.shape[1] == len(ur5.links)
    J = kin.jacobian("ur5", Q, link="tool0", reference="local")
    np.testing.assert_array_equal(J, compile_model(ur5).jacobian(Q, "tool0", "local"))
    assert kin.last_headers["x-reference"] == "local"


def test_ik_and_velocity(server, ur5):
    kin = Client(server.url)
    Q = ur5.sample_configurations(5, np.random.default_rng(2))
    T = compile_model(ur5).fk(Q, ["tool0"])[:, 0]
    answer = kin.ik("ur5", T, link="tool0")
    assert answer["success"].all() and answer["q"].shape == (5, 6)
    np.testing.assert_allclose(compile_model(ur5).fk(answer["q"], ["tool0"])[:, 0], T, atol=1e-5)
    one = kin.ik("ur5", T[0], link="tool0")
    assert one["q"].shape in ((6,), (1, 6))
    free = kin.ik("ur5", T, link="tool0", avoid_collisions=True)
    assert set(free) >= {"q", "success", "collision_free"} and np.all(free["success"] <= free["collision_free"])
    assert np.array_equal(free["collision_free"], api.collision_free(ur5, free["q"]))
    Qd = np.random.default_rng(3).normal(size=Q.shape)
    V = kin.velocity("ur5", Q, Qd, links=["tool0"])
    assert set(V) == {"world", "local", "local_world_aligned"}
    J = compile_model(ur5).jacobian(Q, "tool0", "local_world_aligned")
    np.testing.assert_allclose(V["local_world_aligned"][:, 0], np.einsum("nij,nj->ni", J, Qd), atol=1e-12)


def test_analytic_jacobian_and_floating_base(server, ur5):
    kin = Client(server.url)
    Q = ur5.sample_configurations(4, np.random.default_rng(4))
    J_r, r = kin.analytic_jacobian("ur5", Q, "zyz", link="tool0")
    task = api.task(ur5, Q, link="tool0", representation="zyz")
    np.testing.assert_array_equal(J_r, task.J_r)
    np.testing.assert_array_equal(r, task.r)
    assert kin.components() == list(task.representation.labels)
    fb = api.model_for(ur5, floating_base=True)
    Qf = fb.sample_configurations(4, np.random.default_rng(5))
    T = kin.fk("ur5", Qf, links=["tool0"], floating_base=True)
    np.testing.assert_array_equal(T, api.fk(ur5, Qf, links=["tool0"], floating_base=True).poses)
    J = kin.jacobian("ur5", Qf, link="tool0", floating_base=True)
    assert J.shape == (4, 6, 12) and kin.joint_names()[0] == "root_joint"


def test_uploads_models_and_api_key(server):
    kin = Client(server.url, api_key=KEY)
    urdf = (FIXTURES / "fixture_arm.urdf") if (FIXTURES / "fixture_arm.urdf").exists() else next(FIXTURES.glob("*.urdf"))
    info = kin.upload_urdf(urdf)
    assert info["id"].startswith("u-") and kin.upload_urdf(urdf.read_text())["id"] == info["id"]
    assert any(m["id"] == info["id"] for m in kin.models())
    assert kin.model(info["id"])["joint_names"] == info["joint_names"]
    dh = kin.upload_dh({"name": "two_link", "convention": "standard",
                        "joints": [{"type": "revolute", "a": 0.5, "alpha": 0, "d": 0, "theta": 0},
                                   {"type": "revolute", "a": 0.4, "alpha": 0, "d": 0, "theta": 0}]})
    assert dh["id"].startswith("dh-") and dh["dof"] == 2
    T = kin.fk(dh["id"], [0.0, 0.0], links=["tool"])
    np.testing.assert_allclose(T[0, 0, :3, 3], [0.9, 0.0, 0.0], atol=1e-12)
    with pytest.raises(ServiceError) as err:
        Client(server.url).upload_urdf(urdf)
    assert err.value.status == 401 and err.value.slug == "api-key-required"
    kin.delete_model(dh["id"])


def test_errors_carry_problem_details(server):
    kin = Client(server.url)
    with pytest.raises(ServiceError) as err:
        kin.fk("no-such-robot", np.zeros((1, 6)))
    e = err.value
    assert e.status == 404 and e.slug == "unknown-model" and e.problem["status"] == 404 and "no-such-robot" in str(e)
    with pytest.raises(ServiceError) as err:
        kin.fk("ur5", np.zeros((2, 5)))
    assert err.value.status == 422 and err.value.detail
    with pytest.raises(ServiceError) as err:
        kin.jacobian("ur5", np.zeros(6), link="nope")
    assert err.value.slug == "unknown-link"
    with pytest.raises(ServiceError) as err:
        Client("http://127.0.0.1:9", timeout=2).models()
    assert err.value.status == 0


def test_client_imports_only_stdlib_and_numpy():
    import ast
    import sys
    from pathlib import Path

    import kinematics.client as module

    tree = ast.parse(Path(module.__file__).read_text())
    roots = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    roots |= {n.module.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module and not n.level}
    assert roots - set(sys.stdlib_module_names) == {"numpy"}
