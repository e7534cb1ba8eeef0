"""Catalogue-wide parity with Pinocchio (what `kinematics check` runs), and the check CLI."""

from __future__ import annotations

import re

import pytest

from kinematics.io.catalogue import default_catalogue
from kinematics.tolerances import AGREEMENT_TOLERANCE as PARITY_TOLERANCE
from kinematics.verify.parity import ParityResult, check_model, summary_line
from tests.catalogue_sample import catalogue_ids

SAMPLES = 5
CATALOGUE_IDS = default_catalogue().ids()


def test_catalogue_is_complete_and_ids_are_readable():
    ids = CATALOGUE_IDS
    assert len(set(ids)) == len(ids)
    erd = [i for i in ids if default_catalogue().entry(i).source == "example-robot-data"]
    assert len(erd) == 68  # every URDF example-robot-data 6.0 ships but the one without a robot name
    for expected in ("ur5", "panda", "talos_reduced", "tiago_dual", "anymal_b", "anymal_c", "xarm7", "z1", "so100"):
        assert expected in ids
    assert all(re.fullmatch(r"[a-z0-9_]+", i) for i in ids)


@pytest.mark.slow
@pytest.mark.parametrize("model_id", catalogue_ids())  # a fixed sample; every model with KIN_TEST_FULL_CATALOGUE=1
def test_catalogue_model_agrees_with_pinocchio(model_id):
    """FK of every link and the three Jacobians of every leaf link, 5 configurations, 1e-9."""
    cat = default_catalogue()
    result = check_model(model_id, lambda: cat.get(model_id), samples=SAMPLES, seed=7)
    assert result.status == "ok", result  # (the catalogue lists only what loads)
    assert result.worst <= PARITY_TOLERANCE


def test_summary_line_format():
    results = [
        ParityResult("a", "ok", 6, 11, 1e-16, 2e-16, 3e-16),
        ParityResult("b", "refused", message="no robot name"),
        ParityResult("c", "FAIL", 6, 11, 1e-3, 0.0, 0.0),
    ]
    assert summary_line(results) == "parity: 1/2 models within 1e-09 (worst 1.000e-03)"


def test_check_cli_prints_table_and_summary(capsys):
    from kinematics.cli import main

    code = main(
        ["check", "--samples", "2", "--model", "ur5", "--model", "double_pendulum_continuous"]
    )
    out = capsys.readouterr().out.strip().splitlines()
    assert code == 0
    assert out[0].split()[:3] == ["model", "dof", "links"]
    assert re.fullmatch(r"parity: 2/2 models within 1e-09 \(worst \d\.\d{3}e-\d\d\)", out[-1])


def test_check_cli_unknown_model_is_a_clear_error(capsys):
    from kinematics.cli import main

    assert main(["check", "--model", "nope"]) == 2
    assert "unknown model 'nope'" in capsys.readouterr().err
