"""URDF -> model: structure, q order, and every malformed case refused with the element named."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import URDFError, UnsupportedJointError, load_urdf, parse_urdf

from tests.paths import FIXTURES


def robot(body: str, name: str = "r") -> str:
    return f'<?xml version="1.0"?><robot name="{name}">{body}</robot>'


def rev(name, parent, child, extra="", axis="0 0 1", origin=""):
    return (
        f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
        f'{origin}<axis xyz="{axis}"/><limit lower="-1" upper="1" effort="1" velocity="1"/>{extra}</joint>'
    )


LINKS_ABC = '<link name="a"/><link name="b"/><link name="c"/>'

MALFORMED = [
    ("truncated", '<robot name="r"><link name="a"/><joint', "not well-formed"),
    ("not xml", "hello", "not well-formed"),
    ("wrong root", '<model name="r"><link name="a"/></model>', "<model>"),
    ("no robot name", '<robot><link name="a"/></robot>', "'name'"),
    ("no links", robot(""), "has no <link>"),
    ("link without name", robot('<link/>'), "<link> number 1"),
    ("duplicate link", robot('<link name="a"/><link name="a"/>'), "duplicate link name 'a'"),
    ("duplicate joint", robot(LINKS_ABC + rev("j", "a", "b") + rev("j", "b", "c")), "duplicate joint name 'j'"),
    ("missing parent link", robot(LINKS_ABC + rev("j", "x", "b")), "joint 'j' names parent link 'x'"),
    ("missing child element", robot(LINKS_ABC + '<joint name="j" type="fixed"><parent link="a"/></joint>'), "joint 'j' has no <child"),
    ("two parents", robot(LINKS_ABC + rev("j1", "a", "c") + rev("j2", "b", "c")), "link 'c' has two parent joints"),
    ("two roots", robot(LINKS_ABC + rev("j1", "a", "b")), "2 root links"),
    ("cycle everywhere", robot('<link name="a"/><link name="b"/>' + rev("j1", "a", "b") + rev("j2", "b", "a")), "cycle"),
    ("cycle off the root", robot(LINKS_ABC + '<link name="d"/>' + rev("j1", "a", "b") + rev("j2", "c", "d") + rev("j3", "d", "c")), "cycle"),
    ("unknown type", robot(LINKS_ABC + '<joint name="j" type="hinge"><parent link="a"/><child link="b"/></joint>'), "joint 'j' has unknown type 'hinge'"),
    ("zero axis", robot('<link name="a"/><link name="b"/>' + rev("j", "a", "b", axis="0 0 0")), "joint 'j' has a zero <axis>"),
    ("nan axis", robot('<link name="a"/><link name="b"/>' + rev("j", "a", "b", axis="nan 0 1")), "joint 'j' <axis xyz>"),
    ("text axis", robot('<link name="a"/><link name="b"/>' + rev("j", "a", "b", axis="x y z")), "joint 'j' <axis xyz>"),
    ("short axis", robot('<link name="a"/><link name="b"/>' + rev("j", "a", "b", axis="0 1")), "expected 3 numbers"),
    ("bad origin", robot('<link name="a"/><link name="b"/>' + rev("j", "a", "b", origin='<origin xyz="1 2 three"/>')), "joint 'j' <origin xyz>"),
    ("inf origin", robot('<link name="a"/><link name="b"/>' + rev("j", "a", "b", origin='<origin rpy="0 inf 0"/>')), "joint 'j' <origin rpy>"),
    ("bad limit", robot('<link name="a"/><link name="b"/><joint name="j" type="prismatic"><parent link="a"/><child link="b"/><limit lower="zero" upper="1"/></joint>'), "joint 'j' <limit lower>"),
    ("inverted limit", robot('<link name="a"/><link name="b"/><joint name="j" type="prismatic"><parent link="a"/><child link="b"/><limit lower="2" upper="1"/></joint>'), "lower limit 2.0 above upper"),
    ("bad mimic", robot(LINKS_ABC + rev("j1", "a", "b") + rev("j2", "b", "c", extra='<mimic joint="j1" multiplier="abc"/>')), "joint 'j2' <mimic multiplier>"),
    ("mimic cycle", robot(LINKS_ABC + rev("j1", "a", "b", extra='<mimic joint="j2"/>') + rev("j2", "b", "c", extra='<mimic joint="j1"/>')), "mimic joints form a cycle"),
    ("mimic of fixed", robot(LINKS_ABC + '<joint name="f" type="fixed"><parent link="a"/><child link="b"/></joint>' + rev("j2", "b", "c", extra='<mimic joint="f"/>')), "mimics 'f', which is a fixed joint"),
    ("external entity", '<?xml version="1.0"?><!DOCTYPE r [<!ENTITY x SYSTEM "file:///etc/passwd">]><robot name="&x;"><link name="a"/></robot>', "DTD or entities"),
    ("billion laughs", '<?xml version="1.0"?><!DOCTYPE l [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;"><!ENTITY c "&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;">]><robot name="&c;"><link name="a"/></robot>', "DTD or entities"),
]


@pytest.mark.parametrize("case,text,message", MALFORMED, ids=[c[0] for c in MALFORMED])
def test_malformed_urdf_is_refused_naming_the_element(case, text, message):
    with pytest.raises(URDFError) as exc:
        parse_urdf(text)
    assert message in str(exc.value), str(exc.value)


def test_floating_and_planar_joints_are_read_in_pinocchios_layout():
    text = robot('<link name="a"/><link name="b"/><link name="c"/>'
                 '<joint name="free" type="floating"><parent link="a"/><child link="b"/></joint>'
                 '<joint name="slide" type="planar"><parent link="b"/><child link="c"/><axis xyz="0 0 2"/></joint>')
    m = parse_urdf(text)
    assert m.joint_names == ("free", "slide") and (m.nq, m.nv, m.dof) == (11, 9, 9)
    assert [s.as_dict() for s in m.layout] == [{"name": "free", "type": "floating", "q": [0, 7], "v": [0, 6]},
                                               {"name": "slide", "type": "planar", "q": [7, 11], "v": [6, 9]}]
    assert m.neutral.tolist() == [0, 0, 0, 0, 0, 0, 1, 0, 0, 1, 0]


@pytest.mark.parametrize("axis", [None, "1 0 0", "0 1 0", "0 0 -1", "0 0.1 1"])
def test_planar_joints_other_than_normal_z_are_refused(axis):
    """Pinocchio makes every URDF planar joint move in the x-y plane of its frame, whatever its axis
    (and URDF's default axis is x): any other normal would disagree with the reference silently."""
    tag = "" if axis is None else f'<axis xyz="{axis}"/>'
    text = robot(f'<link name="a"/><link name="b"/><joint name="slide" type="planar"><parent link="a"/>'
                 f'<child link="b"/>{tag}</joint>')
    with pytest.raises(UnsupportedJointError, match="planar joint 'slide' has plane normal"):
        parse_urdf(text)


@pytest.mark.parametrize("body", [
    '<joint name="f" type="floating"><parent link="a"/><child link="b"/><mimic joint="r"/></joint>',
    '<joint name="f" type="planar"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint>'
    '<joint name="m" type="revolute"><parent link="a"/><child link="d"/><axis xyz="0 0 1"/>'
    '<limit lower="-1" upper="1" effort="1" velocity="1"/><mimic joint="f"/></joint>',
])
def test_mimic_of_or_by_a_multi_dof_joint_is_refused(body):
    text = robot('<link name="a"/><link name="b"/><link name="c"/><link name="d"/>'
                 '<joint name="r" type="revolute"><parent link="a"/><child link="c"/><axis xyz="0 0 1"/>'
                 '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>' + body)
    with pytest.raises(UnsupportedJointError, match="mimic"):
        parse_urdf(text)


def test_link_limit():
    links = "".join(f'<link name="l{i}"/>' for i in range(20))
    joints = "".join(f'<joint name="j{i}" type="fixed"><parent link="l{i}"/><child link="l{i+1}"/></joint>' for i in range(19))
    assert parse_urdf(robot(links + joints)).links[-1] == "l19"
    with pytest.raises(URDFError, match="limit is 10"):
        parse_urdf(robot(links + joints), max_links=10)


def test_structure_of_tree_fixture():
    m = load_urdf(FIXTURES / "tree_mimic.urdf")
    assert m.root == "base"
    # q order: document order of moving, non-mimic joints
    assert m.joint_names == ("right_shoulder", "torso_joint", "left_shoulder", "left_elbow", "right_slide_joint")
    assert m.dof == 5
    assert set(m.leaf_links) == {"left_tip", "right_finger", "head"}
    j = m.joint_map["left_elbow"]
    np.testing.assert_allclose(np.linalg.norm(j.axis), 1.0)  # normalised
    np.testing.assert_allclose(j.axis, np.array([0.3, -0.4, 0.5]) / np.linalg.norm([0.3, -0.4, 0.5]))
    assert m.joint_map["right_shoulder"].limits is None  # continuous
    mim = m.joint_map["right_finger_joint"].mimic
    assert (mim.leader, mim.multiplier, mim.offset) == ("left_elbow", -0.7, 0.15)
    assert m.resolve_mimic(m.joint_map["right_finger_joint"]) == ("left_elbow", -0.7, 0.15)
    assert len(m.content_hash) == 64
    assert m.lower_limits[0] == -np.inf and m.upper_limits[1] == 2.0


def test_mimic_of_missing_joint_becomes_independent_with_warning():
    text = robot(LINKS_ABC + rev("j1", "a", "b") + rev("j2", "b", "c", extra='<mimic joint="ghost"/>'))
    m = parse_urdf(text)
    assert m.joint_names == ("j1", "j2")
    assert any("ghost" in w and "independent" in w for w in m.warnings)


def test_mimic_chain_composes():
    text = robot(
        LINKS_ABC + '<link name="d"/>'
        + rev("j1", "a", "b")
        + rev("j2", "b", "c", extra='<mimic joint="j1" multiplier="2" offset="0.1"/>')
        + rev("j3", "c", "d", extra='<mimic joint="j2" multiplier="-3" offset="0.5"/>')
    )
    m = parse_urdf(text)
    assert m.joint_names == ("j1",)
    leader, mult, off = m.resolve_mimic(m.joint_map["j3"])
    # q3 = -3 (2 q1 + 0.1) + 0.5 = -6 q1 + 0.2
    assert leader == "j1" and mult == pytest.approx(-6.0) and off == pytest.approx(0.2)


def test_meshes_are_recorded_not_opened(tmp_path):
    mesh = tmp_path / "secret.stl"
    mesh.write_text("not a mesh")
    text = robot(f'<link name="a"><visual><geometry><mesh filename="{mesh}"/></geometry></visual></link>')
    import sys

    opened = []

    def hook(event, args):
        if event == "open" and str(mesh) in str(args[0]):
            opened.append(args)

    sys.addaudithook(hook)
    m = parse_urdf(text)
    assert m.visuals["a"][0].kind == "mesh"
    assert not opened


def test_primitive_visuals_parsed():
    text = robot('<link name="a"><visual><origin xyz="0 0 0.5"/><geometry><cylinder radius="0.1" length="1"/></geometry></visual>'
                 '<visual><geometry><box size="1 2 3"/></geometry></visual></link>')
    v = parse_urdf(text).visuals["a"]
    assert v[0].kind == "cylinder" and v[0].size == (0.1, 1.0) and v[0].origin[2, 3] == 0.5
    assert v[1].kind == "box" and v[1].size == (1.0, 2.0, 3.0)
