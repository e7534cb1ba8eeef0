"""`kinematics ik --all --avoid-collisions`, `kinematics ik-path --avoid-collisions` and
`kinematics workspace --collision-free`."""

from __future__ import annotations

import csv

import numpy as np

from kinematics import compile_model, default_catalogue, usecases
from tests.helpers import run_cli as run

SAMPLES = "300"


def test_ik_all_avoid_collisions(tmp_path, capsys):
    ur5 = default_catalogue().get("ur5")
    Q = ur5.sample_configurations(12, np.random.default_rng(0))
    T = compile_model(ur5).fk(Q, ["tool0"])[:, 0]
    np.save(tmp_path / "T.npy", T)
    lib = usecases.ik(ur5, T, link="tool0", solutions="all", avoid_collisions=True, collision_samples=int(SAMPLES))
    assert lib.colliding.sum() > 0
    out = tmp_path / "free.csv"
    code, _, err = run(["ik", "--model", "ur5", "--link", "tool0", "--all", "--avoid-collisions",
                        "--collision-samples", SAMPLES, tmp_path / "T.npy", "-o", out], capsys)
    assert code == (1 if (lib.count == 0).any() else 0), err
    rows = list(csv.reader(open(out)))[1:]
    assert len(rows) == lib.count.sum()
    assert f"{lib.colliding.sum()} solutions left out as in self-collision" in err
    q = np.array([[float(v) for v in r[1:7]] for r in rows])
    assert usecases.collision_free(ur5, q, samples=int(SAMPLES)).all()


def test_ik_path_avoid_collisions_and_workspace_collision_free(tmp_path, capsys):
    ur5 = default_catalogue().get("ur5")
    q0, q1 = [0, -1.0, 1.5, 0, 0, 0], [0, -1.0, 2.9, 0, 0, 0]
    np.save(tmp_path / "w.npy", compile_model(ur5).fk(np.array([q0, q1], dtype=float), ["tool0"])[:, 0])
    out = tmp_path / "path.csv"
    code, _, err = run(["ik-path", "--model", "ur5", "--link", "tool0", "--seed=" + ",".join(map(str, q0)),
                        "--avoid-collisions", "--collision-samples", SAMPLES, tmp_path / "w.npy", "-o", out], capsys)
    assert code == 1 and ": collision" in err, err
    rows = list(csv.reader(open(out)))[1:]
    assert f"stopped at target {len(rows)}: collision" in err
    code, text, err = run(["workspace", "--model", "ur5", "--link", "tool0", "-n", "1000", "--collision-free",
                           "--collision-samples", SAMPLES], capsys)
    assert code == 0, err
    assert "in self-collision dropped" in text
    code, _, err = run(["workspace", "--model", "puma560_standard", "-n", "100", "--collision-free"], capsys)
    assert code == 2 and "no collision geometry" in err


def test_a_model_without_collision_geometry_fails_before_any_output(tmp_path, capsys):
    puma = default_catalogue().get("puma560_standard")
    np.save(tmp_path / "T.npy", compile_model(puma).fk(np.zeros((1, puma.dof)), ["tool"])[:, 0])
    for extra in (["--all"], []):
        code, out, err = run(["ik", "--model", "puma560_standard", *extra, "--avoid-collisions", tmp_path / "T.npy"],
                             capsys)
        assert code == 2 and out == "" and "no collision geometry" in err
