"""Identifiability: the rank of the identification Jacobian is the complete-and-minimal count."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics.algorithms.calibration.errors_model import ErrorModel
from kinematics.algorithms.calibration.identification import identify, residual_and_jacobian

CHAINS = [("ur5", "tool0"), ("panda", "panda_link8"), ("puma560_standard", None), ("stanford_arm", None)]


def identification(catalogue, mid, link, measure, parameters="full", point=(0.05, 0.03, 0.1)):
    model = catalogue.get(mid)
    link = link or model.links[-1]
    em = ErrorModel(model, link, measure, parameters, point=np.asarray(point))
    Q = model.sample_configurations(60, np.random.default_rng(1))
    T = em.predict(Q, em.x0)
    _, J = residual_and_jacobian(em, Q, em.x0, T[:, :3, 3] if measure == "position" else T)
    return em, identify(em, J.reshape(-1, len(em.x0)), measure)


@pytest.mark.parametrize("mid,link", CHAINS)
@pytest.mark.parametrize("measure", ["position", "pose"])
def test_rank_is_4R_plus_2P_plus_6_or_3(catalogue, mid, link, measure):
    em, ident = identification(catalogue, mid, link, measure)
    R = sum(j.type != "prismatic" for j in em.joints)
    P = len(em.joints) - R
    assert (mid != "stanford_arm") or P == 1  # the chain with a prismatic joint
    assert ident.rank == 4 * R + 2 * P + (6 if measure == "pose" else 3)
    assert len(ident.selected) == ident.rank
    assert len(ident.unidentifiable) == len(em.names) - ident.rank
    # the gap is clean: the first discarded singular value is rounding
    assert ident.singular_values[ident.rank - 1] > 1e-3 > 1e-10 > ident.singular_values[ident.rank]


def test_the_reasons_name_what_absorbs_a_parameter(catalogue):
    em, ident = identification(catalogue, "ur5", "tool0", "position")
    why = {u["name"]: u["reason"] for u in ident.unidentifiable}
    first = em.joints[0].name
    assert all(why[f"{first}.{c}"] == "absorbed by the base frame" for c in ("x", "y", "z", "roll", "pitch", "yaw", "offset"))
    # a revolute joint's rotation about its own axis is its zero offset (ur5's wrist_2 turns about z)
    assert why["wrist_2_joint.yaw"] == "the same motion as wrist_2_joint.offset"
    assert why["wrist_1_joint.y"] == "absorbed by the next joint (wrist_2_joint)"
    assert all(u["reason"] for u in ident.unidentifiable)


def test_a_marker_on_the_last_axis_does_not_see_that_joint(catalogue):
    em, ident = identification(catalogue, "ur5", "tool0", "position", point=(0.0, 0.0, 0.0))
    why = {u["name"]: u["reason"] for u in ident.unidentifiable}
    assert why["wrist_3_joint.offset"] == "unobservable from positions"
    assert ident.rank < 27


def test_joint_offsets_only(catalogue):
    em, ident = identification(catalogue, "ur5", "tool0", "position", parameters="joint_offsets")
    assert ident.rank == 6 + 3 + 4  # base, point, the four zeros the base and point do not absorb
    why = {u["name"]: u["reason"] for u in ident.unidentifiable}
    assert why == {"shoulder_pan_joint.offset": "absorbed by the base frame", "wrist_3_joint.offset": "absorbed by the tool"}
