"""A lean library with extras: ``pip install kinematics-service`` brings only what the core
needs, and a feature whose extra is missing fails where it is used with the ``pip install``
to run (:class:`kinematics.errors.MissingExtraError`).

The missing extras are simulated in a fresh interpreter whose import system refuses the heavy
modules (a finder first on ``sys.meta_path``), so these tests run in the full environment.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import textwrap
import tomllib

import pytest

from tests.paths import REPO

PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())
#: what the core must not need (each belongs to an extra)
HEAVY = {"fastapi", "uvicorn", "starlette", "pydantic", "pydantic-settings", "orjson", "fastapi-offline",
         "prometheus-client", "httptools", "uvloop", "pin", "example-robot-data", "mujoco", "xacro", "sympy",
         "matplotlib", "rosbags", "pyarrow", "mcap", "dask", "scipy", "torch"}
#: the import names of the heavy distributions, refused by the simulated lean interpreter
BLOCKED = ["fastapi", "uvicorn", "starlette", "pydantic", "pydantic_settings", "orjson", "fastapi_offline",
           "prometheus_client", "pinocchio", "example_robot_data", "mujoco", "xacro", "sympy", "matplotlib",
           "rosbags", "pyarrow", "mcap", "dask", "scipy", "torch", "coal"]


def _name(requirement: str) -> str:
    return re.split(r"[\s\[<>=!~;]", requirement, maxsplit=1)[0].lower()


def test_the_core_dependencies_are_lean():
    core = {_name(r) for r in PYPROJECT["project"]["dependencies"]}
    assert {"numpy", "numba", "yourdfpy", "defusedxml", "pyyaml"} <= core
    assert not core & HEAVY, core & HEAVY


def test_every_heavy_dependency_is_in_an_extra_and_all_gathers_the_user_extras():
    extras = PYPROJECT["project"]["optional-dependencies"]
    for extra, wanted in {"service": {"fastapi", "uvicorn", "pydantic", "pydantic-settings", "prometheus-client",
                                      "threadpoolctl"},
                          "verify": {"pin"}, "catalogue": {"example-robot-data"}, "mjcf": {"mujoco"},
                          "xacro": {"xacro"}, "symbolic": {"sympy"}, "plot": {"matplotlib"},
                          "logs": {"rosbags", "pyarrow"}}.items():
        assert wanted <= {_name(r) for r in extras[extra]}, extra
    (everything,) = extras["all"]
    named = set(re.search(r"\[(.*)\]", everything).group(1).split(","))
    assert _name(everything) == PYPROJECT["project"]["name"]
    assert named == {"service", "verify", "catalogue", "mjcf", "xacro", "symbolic", "plot", "logs", "dask", "calibration", "collision"}
    assert not named & {"test", "bench", "ik-baselines"}  # not the benchmarks' baselines


def _lean(code: str) -> dict:
    """Run ``code`` in an interpreter that cannot import the heavy modules; it prints JSON."""
    prelude = textwrap.dedent(f"""
        import importlib.abc, json, sys

        class Lean(importlib.abc.MetaPathFinder):
            def find_spec(self, name, path=None, target=None):
                if name.partition(".")[0] in {BLOCKED!r}:
                    raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
                return None

        sys.meta_path.insert(0, Lean())

        import sysconfig  # and no installed data files (example-robot-data's URDFs live there)
        _paths = sysconfig.get_paths
        sysconfig.get_paths = lambda *a, **k: {{**_paths(*a, **k), "purelib": "/nonexistent", "platlib": "/nonexistent"}}
    """)
    r = subprocess.run([sys.executable, "-c", prelude + textwrap.dedent(code)], capture_output=True, text=True,
                       timeout=300, cwd=REPO, env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin",
                                                   "NUMBA_CACHE_DIR": str(REPO / ".pytest_cache" / "numba-lean")})
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_fk_and_jacobians_work_without_any_extra():
    out = _lean("""
        import numpy as np
        import kinematics
        from kinematics.errors import MissingExtraError

        cat = kinematics.default_catalogue()
        ur5 = cat.get("ur5_dh")
        q = np.array([[0.1, -0.5, 0.4, 0.2, 0.3, -0.1]] * 2)
        T = kinematics.fk(ur5, q, links=["tool"]).poses
        J = kinematics.jacobian(ur5, q, link="tool", reference="local_world_aligned").jacobians
        # the Jacobian's linear rows are the rates of the FK position (central differences)
        h, dp = 1e-6, []
        for k in range(6):
            e = np.zeros(6); e[k] = h
            plus = kinematics.fk(ur5, q[:1] + e, links=["tool"]).poses[0, 0, :3, 3]
            minus = kinematics.fk(ur5, q[:1] - e, links=["tool"]).poses[0, 0, :3, 3]
            dp.append((plus - minus) / (2 * h))
        print(json.dumps({"T": list(T.shape), "J": list(J.shape), "rate": float(np.abs(np.array(dp).T - J[0, :3]).max()),
                          "sources": sorted({e.source for e in cat.entries.values()}), "notes": cat.notes,
                          "heavy": sorted(m for m in sys.modules if m.partition(".")[0] in {"sympy", "pinocchio", "fastapi"})}))
    """)
    assert out["T"] == [2, 1, 4, 4] and out["J"] == [2, 6, 6]
    assert out["rate"] < 1e-7
    assert out["sources"] == ["preset"]  # no example-robot-data: only the DH presets of models/
    assert out["notes"] and "pip install 'kinematics-service[catalogue]'" in out["notes"][0]
    assert out["heavy"] == []


@pytest.mark.parametrize("extra, code", [
    ("verify", "kinematics.fk(kinematics.default_catalogue().get('planar_2r'), [0.1, 0.2], verify=True)"),
    ("catalogue", "kinematics.default_catalogue().get('ur5')"),
    ("mjcf", "__import__('kinematics.io.mjcf').io.mjcf.compile_mjcf('<mujoco><worldbody/></mujoco>')"),
    ("symbolic", "__import__('kinematics.api').api.symbolic_dh({'joints': [{'type': 'R', 'a': 1, 'alpha': 0, "
                 "'d': 0, 'theta': 0}]}, timeout=None)"),
    ("xacro", "__import__('kinematics.io.xacro').io.xacro.parse_xacro('<robot name=\"r\"><link name=\"a\"/></robot>')"),
    ("dask", "__import__('kinematics.distributed').distributed._dask()"),
    ("collision", "__import__('kinematics.usecases').usecases.collision(kinematics.default_catalogue().get('planar_2r'), "
                  "[0.1, 0.2])"),
    ("calibration", "__import__('kinematics.usecases').usecases.calibration_poses("
                    "kinematics.default_catalogue().get('planar_2r'), 4)"),
])
def test_a_missing_extra_names_the_pip_install_to_run(extra, code):
    out = _lean(f"""
        import kinematics
        try:
            {code}
        except kinematics.KinematicsError as exc:
            print(json.dumps({{"type": type(exc).__name__, "message": str(exc), "import_error": isinstance(exc, ImportError)}}))
        else:
            print(json.dumps({{"type": None}}))
    """)
    assert f"pip install 'kinematics-service[{extra}]'" in out["message"], out
    if extra == "catalogue":  # an unknown id, with the catalogue's note
        assert out["type"] == "UnknownModelError"
    else:
        assert out["type"] == "MissingExtraError" and out["import_error"], out


def test_the_command_line_and_the_client_need_no_extra():
    out = _lean("""
        from kinematics.cli import build_parser
        commands = sorted(build_parser()._subparsers._group_actions[0].choices)
        import kinematics.client
        print(json.dumps({"commands": commands}))
    """)
    assert {"check", "fk", "symbolic", "workspace", "serve"} <= set(out["commands"])


def test_serve_without_the_service_extra_says_what_to_install():
    out = _lean("""
        import contextlib, io
        from kinematics.cli import main
        err = io.StringIO()
        with contextlib.redirect_stderr(err):
            code = main(["serve", "--port", "8799"])
        print(json.dumps({"code": code, "message": err.getvalue()}))
    """)
    assert out["code"] == 2, out
    assert "the REST service (kinematics serve): the optional dependency 'fastapi' is not installed; " \
           "run pip install 'kinematics-service[service]'" in out["message"]


def test_the_service_answers_a_missing_extra_with_501_naming_the_install():
    import orjson

    from app.errors import kinematics_problem
    from kinematics.errors import MissingExtraError

    response = kinematics_problem(MissingExtraError.of("verify", "verification against Pinocchio", "pinocchio"))
    body = orjson.loads(response.body)
    assert response.status_code == 501 and body["type"].endswith(":extra-not-installed")
    assert "pip install 'kinematics-service[verify]'" in body["detail"]
