"""The request shape (kinematics.usecases.query.Query): frozen, validated once when built, the shared
steps of every use case, and q read by the model layer in every form on its way to the engine."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import kinematics
from kinematics import api, usecases
from kinematics.errors import (BudgetError, JointValueError, KinematicsError, LimitError, PoseError,
                               SymbolicTimeoutError, TimeBudgetError, UnknownLinkError)
from kinematics.model.joint_values import as_batch, read_joint_values
from kinematics.usecases import Budget, Query


def test_a_query_is_frozen_with_slots(ur5):
    query = Query(ur5, links=["tool0"])
    with pytest.raises(dataclasses.FrozenInstanceError):
        query.links = ["base_link"]
    assert not hasattr(query, "__dict__")


def test_a_query_is_validated_when_built(ur5):
    with pytest.raises(KinematicsError, match="limits"):
        Query(ur5, limits="ignore")
    with pytest.raises(PoseError, match="not both"):
        Query(ur5, point=[0, 0, 0.1], tool={"xyz": [0, 0, 0], "rpy": [0, 0, 0]})
    with pytest.raises(PoseError, match="point"):
        Query(ur5, point=[0, 0])
    query = Query(ur5, tool={"xyz": [0, 0, 0.2], "rpy": [0, 0, 0]})
    np.testing.assert_allclose(query.T_tool[:3, 3], [0, 0, 0.2])
    assert Query(ur5).T_tool is None and Query(ur5).robot is ur5


def test_floating_base_is_resolved_once(ur5):
    query = Query(ur5, floating_base=True)
    assert query.robot is usecases.model_for(ur5, True) and query.robot.nq == 7 + 6
    assert query.replace(floating_base=False).robot is ur5


def test_the_shared_steps(ur5):
    query = Query(ur5, links="all", budget=Budget(max_batch=2, max_verify=1, max_result_values=10_000), verify=True)
    Q, is_batch = query.joints([[0.0] * 6, [0.1] * 6])
    assert Q.shape == (2, 6) and is_batch
    with pytest.raises(BudgetError) as exc:
        query.joints([[0.0] * 6] * 3)
    assert exc.value.budget == "batch"
    assert query.link_names() == list(ur5.links) and Query(ur5).link_names() == list(ur5.leaf_links)
    assert Query(ur5).link_names(default="all") == list(ur5.links)
    assert Query(ur5).frame_link() == ur5.leaf_links[0]
    with pytest.raises(UnknownLinkError):
        Query(ur5, link="nope").frame_link()
    with pytest.raises(BudgetError) as exc:
        query.check_sizes(2, 16, "two poses")
    assert exc.value.budget == "verify"
    assert query.base_poses(3) is None
    assert Query(ur5, base={"xyz": [1, 0, 0], "rpy": [0, 0, 0]}).base_poses(3).shape == (3, 4, 4)
    with pytest.raises(LimitError):
        Query(ur5, limits="refuse").joints([10.0] * 6)


def test_the_shared_steps_of_ik(ur5):
    query = Query(ur5, budget=Budget(max_batch=2, max_verify=1), verify=True)
    T, is_batch = query.targets(np.eye(4))
    assert T.shape == (1, 4, 4) and not is_batch
    with pytest.raises(BudgetError) as exc:
        query.targets(np.stack([np.eye(4)] * 2))
    assert exc.value.budget == "verify"
    with pytest.raises(BudgetError) as exc:
        Query(ur5, budget=Budget(max_batch=2)).targets(np.stack([np.eye(4)] * 3))
    assert exc.value.budget == "batch"
    assert query.seeds(None, 3) is None
    assert query.seeds([0.1] * 6, 3).shape == (1, 6) and query.seeds([[0.1] * 6] * 3, 3).shape == (3, 6)
    with pytest.raises(JointValueError, match=r"^seed: 2 seeds for 3 targets"):
        query.seeds([[0.1] * 6] * 2, 3)
    with pytest.raises(JointValueError, match=r"^seed: "):
        query.seeds([0.1] * 5, 1)


def test_every_use_case_takes_a_query_or_a_model_and_keywords(ur5):
    q = [0.1, -1.0, 1.2, 0.3, 0.5, -0.2]
    query = Query(ur5, link="tool0", links=["tool0"], point=[0, 0, 0.1])
    by_query = usecases.fk(query, q).poses
    np.testing.assert_array_equal(by_query, api.fk(ur5, q, links=["tool0"], point=[0, 0, 0.1]).poses)
    np.testing.assert_array_equal(usecases.jacobian(query, q, reference="local").jacobians,
                                  api.jacobian(ur5, q, link="tool0", point=[0, 0, 0.1], reference="local").jacobians)
    np.testing.assert_array_equal(usecases.velocity(query, q, [1.0] * 6).linear,
                                  api.velocity(ur5, q, [1.0] * 6, links=["tool0"], point=[0, 0, 0.1]).linear)
    answer = usecases.ik(query.replace(links=None), by_query[0, 0], restarts=2)
    assert answer.solution.success[0] and answer.link == "tool0"
    ws = usecases.workspace(query, samples=500)
    assert ws.link == "tool0" and ws.samples == 500
    r = usecases.task(query, q, representation="position").r
    np.testing.assert_allclose(r[0], by_query[0, 0, :3, 3], atol=1e-12)
    # the package exports them, and the facade is the same functions
    assert kinematics.ik is usecases.ik is api.ik and kinematics.Query is Query and kinematics.velocity is api.velocity
    with pytest.raises(TypeError):
        usecases.fk(ur5, q, reference="world")  # not a field of the query, not an argument of fk


def test_q_is_read_by_the_model_layer_in_every_form(catalogue):
    """Vectors, name maps, lists of those, a floating joint given as a pose object: as_batch reads them
    all (no use case pre-processes q), and read_joint_values reads a batch of lists as one array."""
    fb = usecases.model_for(catalogue.get("ur5"), floating_base=True)
    names = [n for n in fb.joint_names if n != "root_joint"]
    as_values = {"root_joint": [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0], **{n: 0.1 for n in names}}
    as_pose = {"root_joint": {"xyz": [1, 2, 3], "rpy": [0, 0, 0]}, **{n: 0.1 for n in names}}
    as_quaternion = {"root_joint": {"position": [1, 2, 3], "quaternion": {"w": 1, "x": 0, "y": 0, "z": 0}},
                     **{n: 0.1 for n in names}}
    expected, _ = as_batch(fb, as_values)
    for form in (as_pose, as_quaternion):
        np.testing.assert_allclose(as_batch(fb, form)[0], expected, atol=1e-15)
        Q, is_batch = as_batch(fb, [form, as_values])
        assert is_batch and Q.shape == (2, 13)
    with pytest.raises(JointValueError, match="configuration 1: joint 'root_joint'"):
        as_batch(fb, [as_values, {**as_pose, "root_joint": {"xyz": [1, 2], "rpy": [0, 0, 0]}}])
    Q, is_batch = read_joint_values(fb, [list(expected[0])] * 4)
    assert Q.shape == (4, 13) and is_batch
    with pytest.raises(JointValueError, match="no configuration"):
        read_joint_values(fb, np.zeros((0, 13)))


def test_symbolic_derives_repeated_entries_once(monkeypatch, catalogue):
    from kinematics.algorithms import symbolic as algorithms_symbolic

    asked = []
    derive = algorithms_symbolic.derive

    def recording(chain, *, what, **kwargs):
        asked.append(what)
        return derive(chain, what=what, **kwargs)

    monkeypatch.setattr(algorithms_symbolic, "derive", recording)
    model = catalogue.get("planar_2r")
    twice = usecases.symbolic(model, what=["transforms", "jacobian", "transforms"], fmt="text", timeout=None).output
    once = usecases.symbolic(model, what=["transforms", "jacobian"], fmt="text", timeout=None).output
    assert asked == [("transforms", "jacobian"), ("transforms", "jacobian")]
    assert {k: v for k, v in twice.items() if k != "seconds"} == {k: v for k, v in once.items() if k != "seconds"}


def test_a_symbolic_time_limit_is_a_time_budget_naming_its_setting(catalogue):
    model = catalogue.get("panda")
    with pytest.raises(TimeBudgetError) as exc:
        usecases.symbolic(model, tip="panda_hand_tcp", what=["transforms", "jacobian"], timeout=0.01,
                          timeout_setting="KIN_SYMBOLIC_TIMEOUT")
    assert isinstance(exc.value, SymbolicTimeoutError)
    assert exc.value.setting == "KIN_SYMBOLIC_TIMEOUT" and exc.value.limit == 0.01 and exc.value.timeout == 0.01
