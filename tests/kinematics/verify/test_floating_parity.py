"""Parity with Pinocchio of models with floating and planar joints, to AGREEMENT_TOLERANCE (1e-9):
every link placement, every link's Jacobian in the three references and every link's twist
(``forwardKinematics(model, data, q, v)`` + ``getFrameVelocity``), at random configurations with
random unit quaternions and planar angles.

- every catalogue model with ``floating_base: true`` against ``buildModelFromXML(urdf,
  JointModelFreeFlyer())`` (the legged robots and humanoids, and every other URDF of the catalogue);
- the fixtures with a floating and a planar joint in the middle of a tree, and at the root.

``pytest -s tests/kinematics/verify/test_floating_parity.py`` prints the counts.
"""

from __future__ import annotations

import numpy as np
import pytest

from kinematics.errors import KinematicsError
from kinematics.io.floating import with_floating_base
from kinematics.io.urdf import load_urdf
from kinematics.tolerances import AGREEMENT_TOLERANCE
from kinematics.verify.pinocchio import compare_fk, compare_jacobian, compare_velocity, reference_for

from tests.paths import FIXTURES

FIXTURE_FILES = ["floating_planar_tree.urdf", "floating_base_arm.urdf"]
#: a tool frame (rotated and offset) for the checks of frames off the links
TOOL = np.array([[0.0, -1.0, 0.0, 0.1], [1.0, 0.0, 0.0, -0.05], [0.0, 0.0, 1.0, 0.2], [0.0, 0.0, 0.0, 1.0]])


def parity(model, samples: int, seed: int = 0, tool=None) -> tuple[float, int]:
    """(worst deviation over FK of every link, the 3 Jacobians of every link, the 3 twists of every link;
    number of links)."""
    rng = np.random.default_rng(seed)
    Q = model.sample_configurations(samples, rng)
    Qd = rng.uniform(-1.0, 1.0, (samples, model.nv))
    fk = compare_fk(model, Q, tool=tool)
    jac = max(compare_jacobian(model, Q, link, tool=tool) for link in model.links)
    vel = compare_velocity(model, Q, Qd, tool=tool)
    return max(fk.worst, jac, vel), len(model.links)


@pytest.mark.parametrize("name", FIXTURE_FILES)
@pytest.mark.parametrize("tool", [None, TOOL], ids=["links", "tool"])
def test_fixtures_with_floating_and_planar_joints_agree_with_pinocchio(name, tool):
    model = load_urdf(FIXTURES / name)
    assert model.multi_dof and model.nq != model.nv
    worst, _ = parity(model, samples=20, tool=tool)
    print(f"\n{name}: worst deviation from Pinocchio {worst:.3e}")
    assert worst < AGREEMENT_TOLERANCE


def test_the_fixture_layouts_are_pinocchios():
    """Pinocchio reads the same URDF into a FreeFlyer (7 q, 6 v) and a Planar joint (4 q, 3 v)."""
    model = load_urdf(FIXTURES / "floating_planar_tree.urdf")
    pm = reference_for(model).pin_model
    kinds = {pm.names[i]: (pm.joints[i].shortname(), pm.joints[i].nq, pm.joints[i].nv) for i in range(1, pm.njoints)}
    assert kinds["float"] == ("JointModelFreeFlyer", 7, 6)
    assert kinds["plane"] == ("JointModelPlanar", 4, 3)
    assert pm.nv == model.nv + 1  # Pinocchio also has the mimic joint's own column


@pytest.mark.slow
def test_every_catalogue_model_with_a_floating_base_agrees_with_pinocchio(catalogue):
    results, refused = [], []
    for model_id in catalogue.ids():
        try:
            model = with_floating_base(catalogue.get(model_id))
            reference_for(model)
        except KinematicsError as exc:
            refused.append(f"{model_id}: {exc}")
            continue
        worst, links = parity(model, samples=3)
        results.append((model_id, worst, links, model.nv))
    failed = [r for r in results if not r[1] < AGREEMENT_TOLERANCE]
    worst = max(r[1] for r in results)
    print(f"\nfloating_base parity: {len(results) - len(failed)}/{len(results)} catalogue models, "
          f"{sum(r[2] for r in results)} links, worst {worst:.3e} (FK, 3 Jacobians and 3 twists of every link); "
          f"refused: {refused}")
    legged = {"solo", "solo12", "anymal_b", "anymal_c", "hyq_no_sensors", "go1", "go2", "a1", "b1", "laikago", "bolt",
              "talos_full_v2", "talos_reduced", "romeo", "icub", "g1_29dof", "simple_humanoid", "tiago"}
    assert legged <= {r[0] for r in results}
    assert not failed, failed
    assert not refused, refused  # the catalogue lists only what loads
