"""Hostile and malformed input through the command line: a clear message, an exit code, no traceback.

Every URDF of the corpus given to ``kinematics fk --urdf`` exits 3 (model cannot be
loaded), every DH table given to ``kinematics dh2urdf`` exits 2 (bad input), and bad joint
value files (object ``.npy`` holding a pickle, NaN, wrong width) exit 2; each prints one
line naming the problem on stderr, never a traceback, and writes no output file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from kinematics.cli import main
from tests.paths import CORPUS
from tests.helpers import write_npy

MANIFEST = yaml.safe_load((CORPUS / "manifest.yaml").read_text())
ARM = CORPUS / "fixture_arm.urdf"
EXIT_USAGE, EXIT_MODEL = 2, 3


def _run(argv, capsys) -> tuple[int, str]:
    code = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, err


@pytest.fixture
def q_csv(tmp_path):
    path = tmp_path / "q.csv"
    path.write_text("0.1,0.2,0.3\n")
    return path


@pytest.mark.parametrize("item", MANIFEST["urdf"], ids=[Path(i["file"]).stem for i in MANIFEST["urdf"]])
def test_corpus_urdf(item, q_csv, tmp_path, capsys):
    out = tmp_path / "out.csv"
    code, err = _run(["fk", "--urdf", CORPUS / item["file"], q_csv, "-o", out], capsys)
    assert code == EXIT_MODEL
    assert item["contains"].lower() in err.lower(), err
    assert len(err.strip().splitlines()) == 1, err
    assert not out.exists()


@pytest.mark.parametrize("item", MANIFEST["dh"], ids=[Path(i["file"]).stem for i in MANIFEST["dh"]])
def test_corpus_dh_table(item, tmp_path, capsys):
    out = tmp_path / "out.urdf"
    code, err = _run(["dh2urdf", CORPUS / item["file"], "-o", out], capsys)
    assert code == EXIT_USAGE
    assert item["contains"].lower() in err.lower(), err
    assert not out.exists()


@pytest.mark.parametrize(
    "name, array, contains",
    [
        ("object", np.array([[0.0, {"x": 1}, 0.0]], dtype=object), "python objects"),
        ("nan", np.array([[0.0, np.nan, 0.0]]), "'j2'"),
        ("wide", np.zeros((2, 4)), "got shape (2, 4)"),
        ("huge", np.array([[0.0, 0.0, 1e300]]), "joint 'j3'): value 1e+300 is beyond"),
    ],
)
def test_bad_joint_value_files(name, array, contains, tmp_path, capsys):
    out = tmp_path / "out.npy"
    code, err = _run(["fk", "--urdf", ARM, write_npy(tmp_path / f"{name}.npy", array), "-o", out], capsys)
    assert code == EXIT_USAGE
    assert contains.lower() in err.lower(), err


def test_path_like_model_id(q_csv, capsys):
    code, err = _run(["fk", "--model", "../../etc/passwd", q_csv], capsys)
    assert code in (EXIT_USAGE, EXIT_MODEL)
    assert "../../etc/passwd" in err and "passwd:" not in err.split("../../etc/passwd", 1)[1][:5]


def test_good_input_still_works(q_csv, tmp_path, capsys):
    """The same command with valid input succeeds (so the refusals above are about the input)."""
    out = tmp_path / "out.csv"
    code, err = _run(["fk", "--urdf", ARM, q_csv, "-o", out], capsys)
    assert code == 0, err
    assert out.read_text().count("\n") == 2


DESCRIPTIONS = [i for i in MANIFEST.get("descriptions", []) if "file" in i and i["status"] != 413
                and not i["file"].endswith(".bin")]


@pytest.mark.parametrize("item", DESCRIPTIONS, ids=[Path(i["file"]).stem for i in DESCRIPTIONS])
def test_corpus_description(item, q_csv, tmp_path, capsys):
    """xacro files through --xacro (the sandbox may read only their directory), MJCF through --mjcf."""
    out = tmp_path / "out.csv"
    option = "--mjcf" if item["file"].endswith(".xml") else "--xacro"
    code, err = _run(["fk", option, CORPUS / item["file"], q_csv, "-o", out], capsys)
    assert code == EXIT_MODEL
    assert item["contains"].lower() in err.lower(), err
    assert item.get("secret", "\0") not in err
    assert not out.exists()
