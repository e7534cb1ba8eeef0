"""Our collision answers against Pinocchio with coal on the same URDF geometry and the same pairs."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from kinematics.algorithms import self_collision
from kinematics.io.catalogue import example_robot_data_dir
from kinematics.verify.pinocchio import compare_collision
from tests.catalogue_sample import catalogue_ids


def _package_dirs():
    return [example_robot_data_dir().parent.parent]  # .../share: holds example-robot-data/robots


@pytest.mark.parametrize("model_id", ["ur5", "panda"])
@pytest.mark.parametrize("margin", [0.0, 0.01])
def test_same_pairs_and_distances_as_pinocchio(catalogue, model_id, margin):
    model = catalogue.get(model_id)
    pairs = self_collision.matrix(model, 1000).enabled()
    Q = model.sample_configurations(300, np.random.default_rng(5))
    ours = self_collision.check(model, Q, pairs=pairs, margin=margin, distance=True)
    assert 0 < ours.colliding.sum() < len(Q)  # the sample meets both answers
    agreement = compare_collision(model, Q, pairs, _package_dirs(), ours.pairs, margin=margin,
                                  distances=ours.min_distance)
    assert agreement.fraction >= 0.997, agreement.mismatches
    assert agreement.max_distance_error < 1e-6


def test_every_pair_of_ur5_against_pinocchio(catalogue):
    """All 28 pairs, adjacent ones (always touching) included."""
    model = catalogue.get("ur5")
    cm = self_collision.geometry(model)
    Q = model.sample_configurations(100, np.random.default_rng(9))
    ours = cm.check(Q, cm.all_pairs())
    agreement = compare_collision(model, Q, cm.all_pairs(), _package_dirs(), ours.pairs)
    assert agreement.same_pairs == 100


@pytest.mark.slow
def test_every_catalogue_model_loads_its_collision_geometry_or_says_what_it_skipped(catalogue):
    for model_id in catalogue_ids():  # a fixed sample; every model with KIN_TEST_FULL_CATALOGUE=1
        if catalogue.entry(model_id).source != "example-robot-data":
            continue
        try:
            model = catalogue.get(model_id)
        except Exception:  # noqa: BLE001 - a catalogue file the URDF reader refuses is tested elsewhere
            continue
        cm = self_collision.geometry(model)
        declared = len(ET.fromstring(model.urdf.encode()).findall("link/collision"))
        kept = sum(len(s) for s in cm.shapes)
        if kept < declared:
            assert cm.warnings, f"{model_id}: {declared - kept} <collision> elements left out without a warning"
        Q = model.sample_configurations(3, np.random.default_rng(0))
        cm.check(Q, cm.all_pairs()[:50])  # the geometry is usable
