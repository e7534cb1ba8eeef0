"""The floating-root fast path (``engine/rooted.py``): which models take it, and that it gives the
numpy tree walk's results (``TreeModel``, the definition held to Pinocchio in
``tests/kinematics/verify/test_floating_parity.py``) to 1e-12 -- FK, the three Jacobians, twists, with
tools and points, whatever the order of q."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics.engine.poe import compile_model
from kinematics.engine.rooted import FloatingRootModel
from kinematics.engine.tree import TreeModel
from kinematics.io.floating import with_floating_base
from kinematics.io.urdf import load_urdf, parse_urdf
from kinematics.tolerances import AGREEMENT_TOLERANCE
from kinematics.verify.pinocchio import compare_fk, compare_jacobian, compare_velocity

from tests.paths import FIXTURES

REFERENCES = ("world", "local", "local_world_aligned")
TOOL = np.array([[0.0, -1.0, 0.0, 0.1], [1.0, 0.0, 0.0, -0.05], [0.0, 0.0, 1.0, 0.2], [0.0, 0.0, 0.0, 1.0]])
POINT = np.eye(4)
POINT[:3, 3] = [0.03, -0.2, 0.11]  # a point: a tool with the link's axes

#: a floating joint that is not first in q (``hip`` is listed before it), with an origin, a link fixed to
#: the root beside it, a mimic joint, a prismatic joint and a fixed chain below it
ROOTED = """<robot name="rooted">
  <link name="world"/><link name="pedestal"/><link name="body"/><link name="upper"/><link name="lower"/>
  <link name="twin"/><link name="tip"/><link name="slide"/>
  <joint name="hip" type="revolute"><parent link="body"/><child link="upper"/>
    <origin xyz="0.1 -0.2 0.05" rpy="0.3 0.1 -0.4"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="pedestal_fixed" type="PEDESTAL"><parent link="world"/><child link="pedestal"/>
    <origin xyz="0.5 0 0.2" rpy="0 0 0.3"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="free" type="floating"><parent link="FREE_PARENT"/><child link="body"/>
    <origin xyz="0.2 0.3 -0.1" rpy="0.5 -0.2 0.8"/></joint>
  <joint name="knee" type="continuous"><parent link="upper"/><child link="lower"/>
    <origin xyz="0 0 -0.3" rpy="0 0.2 0"/><axis xyz="1 0 0"/></joint>
  <joint name="knee_twin" type="revolute"><parent link="upper"/><child link="twin"/>
    <origin xyz="0 0.1 -0.3" rpy="0 0 0"/><axis xyz="0 0.6 0.8"/><limit lower="-3" upper="3" effort="1" velocity="1"/>
    <mimic joint="knee" multiplier="-0.7" offset="0.2"/></joint>
  <joint name="tip_fixed" type="fixed"><parent link="lower"/><child link="tip"/><origin xyz="0.05 0 -0.25" rpy="0.1 0 0"/></joint>
  <joint name="slider" type="prismatic"><parent link="body"/><child link="slide"/>
    <origin xyz="-0.1 0 0.1" rpy="0 0 0"/><axis xyz="0.6 0 0.8"/><limit lower="-0.2" upper="0.3" effort="1" velocity="1"/></joint>
</robot>"""


def rooted(free_parent: str = "world", pedestal: str = "fixed"):
    return parse_urdf(ROOTED.replace("FREE_PARENT", free_parent).replace("PEDESTAL", pedestal))


def fast_path_models(catalogue):
    return {"ur5 floating_base": with_floating_base(catalogue.get("ur5")),
            "solo12 floating_base": with_floating_base(catalogue.get("solo12")),
            "talos_reduced floating_base": with_floating_base(catalogue.get("talos_reduced")),
            "floating joint not first in q": rooted(),
            "floating joint under a link fixed to the root": rooted(free_parent="pedestal")}


def test_the_fast_path_is_chosen_for_floating_root_models(catalogue):
    for name, model in fast_path_models(catalogue).items():
        eng = compile_model(model)
        assert type(eng) is FloatingRootModel, name
    fb = with_floating_base(catalogue.get("solo12"))
    assert compile_model(fb).sub is compile_model(fb.base_model)  # the fixed-base model's compiled form, shared
    m = rooted()
    assert m.joint_names[:2] == ("hip", "free") and compile_model(m).qb == 1 and compile_model(m).vb == 1


def test_other_multi_dof_models_keep_the_tree_walk():
    others = {
        "floating joint below a revolute joint, planar joint": load_urdf(FIXTURES / "floating_planar_tree.urdf"),
        "floating root and a planar joint": load_urdf(FIXTURES / "floating_base_arm.urdf"),
        "floating joint below a revolute joint": rooted(free_parent="pedestal", pedestal="revolute"),
        "a moving joint off the floating joint's sub-tree": rooted(pedestal="revolute"),
    }
    for name, model in others.items():
        assert type(compile_model(model)) is TreeModel, name


@pytest.mark.parametrize("name", ["ur5 floating_base", "solo12 floating_base", "floating joint not first in q",
                                  "floating joint under a link fixed to the root"])
def test_the_fast_path_equals_the_tree_walk(catalogue, name, rng):
    model = fast_path_models(catalogue)[name]
    fast, walk = compile_model(model), TreeModel(model)
    Q = model.sample_configurations(40, rng)
    V = rng.uniform(-1.0, 1.0, (40, model.nv))
    links = list(model.links)
    some = links[::-3]  # a subset, out of order, the root link included
    for tool in (None, TOOL, POINT):
        np.testing.assert_allclose(fast.fk(Q, tool=tool), walk.fk(Q, tool=tool), atol=1e-12, rtol=0)
        np.testing.assert_allclose(fast.fk(Q, some, tool=tool), walk.fk(Q, some, tool=tool), atol=1e-12, rtol=0)
        for link in links:
            for ref in REFERENCES:
                np.testing.assert_allclose(fast.jacobian(Q, link, ref, tool=tool), walk.jacobian(Q, link, ref, tool=tool),
                                           atol=1e-12, rtol=0, err_msg=f"{link} {ref}")
        for subset in (None, some):
            ours, theirs = fast.velocity(Q, V, subset, tool=tool), walk.velocity(Q, V, subset, tool=tool)
            assert ours.keys() == theirs.keys()
            for ref in ours:
                np.testing.assert_allclose(ours[ref], theirs[ref], atol=1e-12, rtol=0, err_msg=ref)
    np.testing.assert_allclose(fast.frames(Q), TreeModel.frames(walk, Q), atol=1e-12, rtol=0)
    np.testing.assert_array_equal(fast.integrate(Q, V), walk.integrate(Q, V))


def test_out_buffers_empty_batches_and_errors(catalogue):
    model = with_floating_base(catalogue.get("solo12"))
    fast = compile_model(model)
    Q = model.sample_configurations(3, np.random.default_rng(1))
    out = np.empty((3, len(model.links), 4, 4))
    assert fast.fk(Q, out=out) is out
    np.testing.assert_array_equal(out, fast.fk(Q))
    strided = np.empty((3, len(model.links), 4, 8))[..., ::2]  # not C-contiguous: filled all the same
    assert fast.fk(Q, out=strided) is strided
    np.testing.assert_array_equal(strided, out)
    assert fast.fk(Q[:0]).shape == (0, len(model.links), 4, 4)
    assert fast.jacobian(Q[:0], "FL_FOOT").shape == (0, 6, model.nv)
    np.testing.assert_array_equal(fast.jacobian(Q, "universe", "local", tool=TOOL), np.zeros((3, 6, model.nv)))
    with pytest.raises(Exception, match="q must have shape"):
        fast.fk(Q[:, 1:])
    with pytest.raises(Exception, match="unknown link"):
        fast.jacobian(Q, "no_such_link")
    with pytest.raises(Exception, match="unknown reference"):
        fast.jacobian(Q, "FL_FOOT", "body")
    with pytest.raises(Exception, match="4x4"):
        fast.jacobian(Q, "FL_FOOT", tool=np.eye(3))


@pytest.mark.parametrize("tool", [None, TOOL], ids=["links", "tool"])
def test_the_floating_joint_not_first_in_q_agrees_with_pinocchio(tool, rng):
    model = rooted()
    Q = model.sample_configurations(8, rng)
    Qd = rng.uniform(-1.0, 1.0, (8, model.nv))
    assert compare_fk(model, Q, tool=tool).worst < AGREEMENT_TOLERANCE
    assert max(compare_jacobian(model, Q, link, tool=tool) for link in model.links) < AGREEMENT_TOLERANCE
    assert compare_velocity(model, Q, Qd, tool=tool) < AGREEMENT_TOLERANCE


def test_batches_split_over_threads_give_the_same_bits(catalogue):
    from kinematics.engine.parallel import FK_MIN_ROWS, threads

    model = with_floating_base(catalogue.get("solo12"))
    fast = compile_model(model)
    Q = model.sample_configurations(2 * FK_MIN_ROWS + 3, np.random.default_rng(2))
    with threads(1):
        fk1, j1 = fast.fk(Q).copy(), fast.jacobian(Q, "FL_FOOT", "local").copy()
    with threads(2):
        np.testing.assert_array_equal(fast.fk(Q), fk1)
        np.testing.assert_array_equal(fast.jacobian(Q, "FL_FOOT", "local"), j1)
