"""The calibration use cases on the Query: measurements in every form, verification, the query's base refused."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import Query, default_catalogue, usecases
from kinematics.algorithms.calibration.synthetic import experiment
from kinematics.errors import BudgetError, CalibrationError, KinematicsError
from kinematics.usecases import Budget


@pytest.fixture(scope="module")
def measured():
    model = default_catalogue().get("ur5")
    rng = np.random.default_rng(31)
    return (model, *experiment(model, "tool0", "pose", 40, rng))


def test_json_maps_csv_and_verification_agree(measured):
    model, truth, Q, T = measured
    query = Query(model, link="tool0", verify=True)
    as_maps = [{"q": dict(zip(model.joint_names, q.tolist())), "pose": t.tolist()} for q, t in zip(Q, T)]
    a = usecases.calibrate(query, as_maps)
    assert a.identifiable == 30 and a.tool is not None
    assert a.verification.max_position_error < 1e-9 and a.verification.reference.startswith("pinocchio")
    from kinematics.spatial.rotations import matrix_to_quaternion

    rows = [",".join(model.joint_names) + ",x,y,z,qw,qx,qy,qz"]
    for q, t in zip(Q, T):
        rows.append(",".join(repr(float(v)) for v in [*q, *t[:3, 3], *matrix_to_quaternion(t[:3, :3])]))
    b = usecases.calibrate(Query(model, link="tool0"), csv="\n".join(rows))
    assert b.verification is None
    assert np.allclose(a.base, b.base, atol=1e-9) and np.allclose(a.tool, b.tool, atol=1e-9)


def test_the_querys_base_is_refused_and_the_budget_holds(measured):
    model, truth, Q, T = measured
    meas = [{"q": q.tolist(), "pose": t.tolist()} for q, t in zip(Q, T)]
    with pytest.raises(KinematicsError, match="estimates the device frame"):
        usecases.calibrate(Query(model, link="tool0", base={"xyz": [0, 0, 0], "rpy": [0, 0, 0]}), meas)
    with pytest.raises(BudgetError):
        usecases.calibrate(Query(model, link="tool0", budget=Budget(max_batch=10)), meas)
    with pytest.raises(CalibrationError, match="not a mix"):
        usecases.calibrate(Query(model, link="tool0"), meas[:5] + [{"q": Q[0].tolist(), "position": [0, 0, 0]}])


def test_calibration_poses_on_the_query():
    model = default_catalogue().get("panda")
    choice = usecases.calibration_poses(Query(model, link="panda_link8", point=[0.0, 0.05, 0.1]), 20, measure="pose")
    assert choice.q.shape == (20, model.dof) and choice.identifiable == 34
    assert choice.log_det > choice.random_log_det
