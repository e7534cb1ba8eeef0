"""URDFs written by other tools: namespaces they never declared (``drake:``), simulator-only
geometry (pybullet's ``<plane>``, ``<cdf>``), extension blocks -- loaded, with what was left out
named in the model's warnings -- and xacro files, which are never read as URDF."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import URDFError, parse_urdf
from kinematics.verify import pinocchio as crosscheck

from tests.paths import FIXTURES

DESCRIPTIONS = FIXTURES / "descriptions"


def _robot(body: str, head: str = "") -> str:
    return f'<robot name="r"{head}><link name="a"/><link name="b"/>{body}</robot>'


JOINT = ('<joint name="j" type="revolute"{attr}><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
         '<limit lower="-1" upper="1" effort="1" velocity="1"/>{extra}</joint>')


def test_undeclared_drake_prefix_is_loaded_and_named_in_warnings():
    model = parse_urdf((DESCRIPTIONS / "drake_extensions.urdf").read_bytes())
    assert model.dof == 1 and model.joint_names == ("j",)
    text = " ".join(model.warnings)
    for name in ("drake:proximity_properties", "drake:rotor_inertia", "drake:collision_filter_group", "drake:foo on <joint>"):
        assert name in text, text
    assert "link 'a' <collision> <plane>" in text and "<cdf>" in text
    # Pinocchio reads the same file, and agrees
    Q = np.array([[0.4], [-0.9]])
    assert crosscheck.compare_fk(model, Q).worst < 1e-12


def test_declared_foreign_namespace_is_ignored_with_its_prefix():
    text = _robot(JOINT.format(attr=' sim:damping="3"', extra="<sim:motor/>"), ' xmlns:sim="http://example.org/sim"')
    model = parse_urdf(text)
    assert model.dof == 1
    assert "<sim:motor>" in model.warnings[0] and "sim:damping on <joint>" in model.warnings[0]


def test_pybullet_plane_and_cdf_geometry_are_ignored():
    model = parse_urdf((DESCRIPTIONS / "pybullet_plane.urdf").read_bytes())
    assert model.joint_names == ("slider",)
    assert model.visuals["planeLink"] == ()  # the <plane> visual is left out, the rest of the link stays
    assert any("<visual> <plane>" in w and "<collision> <cdf>" in w for w in model.warnings), model.warnings
    T = crosscheck.reference_for(model).poses(np.array([0.5]))["pole"]
    np.testing.assert_allclose(T[:3, 3], [0.5, 0, 1], atol=1e-12)


def test_unknown_top_level_elements_are_ignored_with_a_warning():
    model = parse_urdf(_robot(JOINT.format(attr="", extra="") + '<ros2_control name="x"><hardware/></ros2_control>'))
    assert model.dof == 1 and "<ros2_control>" in model.warnings[0]


def test_extension_blocks_of_the_urdf_specification_are_silent():
    body = JOINT.format(attr="", extra="") + '<gazebo reference="a"><material>Gazebo/Red</material></gazebo>' \
        '<transmission name="t"><type>x</type></transmission>'
    assert parse_urdf(_robot(body)).warnings == ()


def test_the_stored_urdf_is_the_file_as_given():
    data = (DESCRIPTIONS / "drake_extensions.urdf").read_bytes()
    model = parse_urdf(data)
    assert model.urdf.encode() == data


def test_a_refusal_still_names_the_element():
    bad = _robot(JOINT.format(attr=' drake:x="1"', extra="").replace('xyz="0 0 1"', 'xyz="0 0 zero"'))
    with pytest.raises(URDFError, match=r"joint 'j' <axis xyz>"):
        parse_urdf(bad)


@pytest.mark.parametrize("name", ["two_link.urdf.xacro", "undeclared_xacro.xacro"])
def test_xacro_given_as_urdf_is_refused_never_a_model_without_joints(name):
    """Was: a .xacro with a robot name became a 0-dof model (every macro silently dropped)."""
    with pytest.raises(URDFError, match="this is a xacro file") as info:
        parse_urdf((DESCRIPTIONS / name).read_bytes())
    assert "<xacro:" in str(info.value) and "--xacro" in str(info.value)


def test_an_expression_left_in_an_attribute_is_xacro():
    with pytest.raises(URDFError, match=r"expression '\$\{pi\}'"):
        parse_urdf(_robot(JOINT.format(attr="", extra="").replace('lower="-1"', 'lower="${pi}"')))


def test_an_unused_xacro_declaration_is_still_urdf():
    """Files xacro wrote keep ``xmlns:xacro`` on <robot>: they are plain URDF."""
    model = parse_urdf(_robot(JOINT.format(attr="", extra=""), ' xmlns:xacro="http://www.ros.org/wiki/xacro"'))
    assert model.dof == 1 and model.warnings == ()


MESHES = ('<link name="a"><visual><geometry><mesh filename="$(find arm_description)/meshes/a.stl"/></geometry>'
          '</visual><collision><geometry><mesh filename="package://$(arg robot)/meshes/${name}.dae"/></geometry>'
          '</collision></link><link name="b"/>')


def _with_meshes(joint: str) -> str:
    return f'<robot name="r">{MESHES}{joint}</robot>'


def test_a_substitution_only_in_mesh_file_names_is_urdf_with_a_warning():
    """Packages ship URDFs whose mesh names keep ``$(find ...)`` / ``$(arg ...)``: the file names
    are never opened, so the file is URDF, and the warning names each element and its text."""
    from kinematics.io.description import detect

    text = _with_meshes(JOINT.format(attr="", extra="").replace("<axis", '<origin xyz="0 0 0.3"/><axis'))
    assert detect(text.encode()) == "urdf"
    model = parse_urdf(text)
    assert model.dof == 1 and model.joint_names == ("j",)
    (warning,) = model.warnings
    assert "link 'a' <visual> <mesh filename='$(find arm_description)/meshes/a.stl'>" in warning
    assert "link 'a' <collision> <mesh filename='package://$(arg robot)/meshes/${name}.dae'>" in warning
    assert "never opened" in warning
    assert model.urdf == text  # stored as given
    Q = np.array([[0.4], [-0.9]])
    assert crosscheck.compare_fk(model, Q).worst < 1e-12  # Pinocchio reads the same file, and agrees


@pytest.mark.parametrize("where, old, new", [
    ("<origin xyz>", "<axis", '<origin xyz="0 0 $(arg height)"/><axis'),
    ("<axis xyz>", 'xyz="0 0 1"', 'xyz="$(arg axis)"'),
    ("<limit upper>", 'upper="1"', 'upper="$(arg upper)"'),
    ("<joint name>", 'name="j"', 'name="$(arg prefix)j"'),
    ("<parent link>", 'link="a"', 'link="$(arg root)"'),
])
def test_a_substitution_that_matters_beside_the_meshes_is_still_xacro(where, old, new):
    from kinematics.io.description import detect

    text = _with_meshes(JOINT.format(attr="", extra="").replace(old, new, 1))
    assert detect(text.encode()) == "xacro"
    with pytest.raises(URDFError, match="this is a xacro file") as info:
        parse_urdf(text)
    assert where in str(info.value) and "--xacro" in str(info.value)


def test_a_substitution_in_other_file_names_is_still_xacro():
    """Only a <mesh filename> of a link's geometry is exempt (a texture, a mesh outside a link's
    <visual>/<collision> are not geometry this reader knows to be unused)."""
    text = '<robot name="r"><link name="a"/><link name="b"/>' + JOINT.format(attr="", extra="") + \
        '<material name="m"><texture filename="$(find pkg)/t.png"/></material></robot>'
    with pytest.raises(URDFError, match=r"<texture filename>"):
        parse_urdf(text)
