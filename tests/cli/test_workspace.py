"""``kinematics workspace``: summary, cloud files, the plot, and bad options."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from kinematics import api, default_catalogue
from tests.helpers import run_cli as run

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def test_ur5_npz_and_plot(tmp_path, capsys):
    code, out, err = run(["workspace", "--model", "ur5", "--link", "tool0", "-n", "20000", "--seed", "4",
                          "-o", tmp_path / "ws.npz", "--plot", tmp_path / "ws.png"], capsys)
    assert code == 0, err
    ws = api.workspace(default_catalogue().get("ur5"), "tool0", samples=20000, random_seed=4)
    assert f"reach         {ws.reach:.4f} m" in out
    assert re.search(r"volume\s+\S+ m\^3; convergence \(samples\): .*\(5000\), .*\(10000\), .*\(20000\)", out)
    z = np.load(tmp_path / "ws.npz")
    np.testing.assert_array_equal(z["points"], ws.points)
    assert float(z["volume"]) == ws.volume
    assert (tmp_path / "ws.png").read_bytes()[:8] == PNG_MAGIC
    from PIL import Image

    assert Image.open(tmp_path / "ws.png").size[0] > 1000  # three slices and the convergence


def test_planar_csv_and_plot(tmp_path, capsys):
    code, out, err = run(["workspace", "--model", "planar_2r", "-n", "50000", "--measure", "position",
                          "-o", tmp_path / "ws.csv", "--plot", tmp_path / "ws.png"], capsys)
    assert code == 0, err
    assert "(planar)" in out
    area = float(re.search(r"area\s+(\S+) m\^2", out).group(1))
    assert area == pytest.approx(math.pi * (0.81 - 0.01), rel=0.02)
    rows = np.loadtxt(tmp_path / "ws.csv", delimiter=",", skiprows=1)
    assert rows.shape == (50000, 4) and rows[:, 3].max() <= 0.2 + 1e-12
    assert (tmp_path / "ws.png").read_bytes()[:8] == PNG_MAGIC


def test_point_and_voxel(tmp_path, capsys):
    code, out, err = run(["workspace", "--model", "scara", "--point", "0,0,-0.05", "-n", "5000", "--voxel", "0.05"],
                         capsys)
    assert code == 0, err
    assert "voxel         0.05 m" in out


@pytest.mark.parametrize("argv, code, fragment", [
    (["--model", "ur5", "-n", "0"], 2, "--samples"),
    (["--model", "ur5", "--voxel", "-1"], 2, "--voxel"),
    (["--model", "ur5", "-o", "x.txt"], 2, ".npz or .csv"),
    (["--model", "ur5", "--plot", "x.jpg"], 2, ".png"),
    (["--model", "ur5", "--point", "1,2"], 2, "--point"),
    (["--model", "ur5", "--link", "nope"], 2, "nope"),
    (["--model", "nope"], 3, "nope"),
])
def test_bad_options(capsys, argv, code, fragment):
    got, _, err = run(["workspace", *argv], capsys)
    assert got == code
    assert fragment in err
