"""`kinematics ik-path --select` on a 7-joint arm: the Panda line that stops with q7 locked goes
through along the self-motion; --redundancy without --select and --select on a 6-joint arm refused."""

from __future__ import annotations

import csv

import numpy as np

from kinematics import compile_model, default_catalogue
from tests.helpers import run_cli as run
from tests.kinematics.algorithms.test_ik_path_redundant import LINK, MOVE, START

SEED = "--seed=" + ",".join(map(str, START))


def test_ik_path_along_the_self_motion(tmp_path, capsys):
    panda = default_catalogue().get("panda")
    a = compile_model(panda).fk(START[None], [LINK])[0, 0]
    b = a.copy()
    b[:3, 3] += MOVE
    np.save(tmp_path / "w.npy", np.array([a, b]))
    out = tmp_path / "path.csv"
    code, _, err = run(["ik-path", "--model", "panda", "--link", LINK, SEED, "--locked", "panda_joint7:0.66",
                        tmp_path / "w.npy", "-o", out], capsys)
    assert code == 1 and "joint_jump" in err
    code, _, err = run(["ik-path", "--model", "panda", "--link", LINK, SEED, "--select", "nearest",
                        "--redundancy", "joint:panda_joint7", tmp_path / "w.npy", "-o", out], capsys)
    assert code == 0 and "fraction 1" in err, err
    rows = list(csv.reader(open(out)))
    Q = np.array(rows[1:], dtype=float)
    assert rows[0] == list(panda.joint_names) and len(Q) == 10
    np.testing.assert_allclose(Q[0], START, atol=1e-9)
    code, _, err = run(["ik-path", "--model", "panda", "--link", LINK, "--redundancy", "joint:panda_joint7",
                        tmp_path / "w.npy", "-o", out], capsys)
    assert code == 2 and "--redundancy needs --select" in err
    code, _, err = run(["ik-path", "--model", "ur5", "--link", "tool0", "--select", "margin",
                        tmp_path / "w.npy", "-o", out], capsys)
    assert code != 0 and "not redundant" in err
