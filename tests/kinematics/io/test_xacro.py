"""xacro: expansion in the sandboxed worker (arguments, packages, real descriptions shipped by
rtb-data and robosuite), and what the sandbox refuses (the hostile corpus has more)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from kinematics.errors import ExpansionLimitError, URDFError, XacroError
from kinematics.io.xacro import SandboxLimits, check_args, expand_text, find_packages, load_xacro, parse_xacro
from kinematics.verify import pinocchio as crosscheck

from tests.paths import FIXTURES

TWO_LINK = (FIXTURES / "descriptions" / "two_link.urdf.xacro").read_bytes()
SITE = Path(np.__file__).resolve().parents[1]
RTB_XACRO = SITE / "rtbdata" / "xacro"
ROBOSUITE_PANDA = SITE / "robosuite" / "models" / "assets" / "bullet_data" / "panda_description"
FAST = SandboxLimits(cpu_seconds=2, memory_bytes=512 * 1024 * 1024, wall_seconds=20)
HEAD = '<robot name="h" xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="a"/>'


def test_text_expands_with_its_default_and_given_arguments():
    model = parse_xacro(TWO_LINK)
    assert model.format == "xacro" and model.joint_names == ("upper_joint", "lower_joint")
    np.testing.assert_allclose(model.joint_map["lower_joint"].origin[:3, 3], [0, 0, 0.5])
    assert model.joint_map["upper_joint"].limits.upper == pytest.approx(np.pi / 2, abs=1e-15)
    longer = parse_xacro(TWO_LINK, args={"length": 0.75})
    np.testing.assert_allclose(longer.joint_map["lower_joint"].origin[:3, 3], [0, 0, 0.75])
    assert "<xacro" not in longer.urdf and "${" not in longer.urdf


def test_the_expansion_is_checked_by_pinocchio():
    model = parse_xacro(TWO_LINK, args={"length": 0.75})
    Q = np.array([[0.3, -0.4], [1.0, 0.2]])
    assert crosscheck.compare_fk(model, Q).worst < 1e-12


@pytest.mark.parametrize("args, message", [
    ({"bad name": 1}, "not a plain name"), ({"x": [1, 2]}, "give a string or a number"), ({"x": "y" * 10_001}, "longer"),
])
def test_bad_arguments_are_refused(args, message):
    with pytest.raises(XacroError, match=message):
        check_args(args)


def test_booleans_and_numbers_become_xacro_strings():
    assert check_args({"a": True, "b": 0.5, "c": 3}) == {"a": "true", "b": "0.5", "c": "3"}


def test_a_missing_argument_is_named():
    text = HEAD + '<link name="$(arg tip)"/></robot>'
    with pytest.raises(XacroError, match="tip"):
        parse_xacro(text, limits=FAST)


def test_an_include_of_a_missing_file_names_it():
    with pytest.raises(XacroError, match="No such file.*other.xacro"):
        parse_xacro(HEAD + '<xacro:include filename="other.xacro"/></robot>', limits=FAST)


def test_a_macro_only_file_says_so():
    text = '<robot xmlns:xacro="http://www.ros.org/wiki/xacro"><xacro:macro name="m"><link name="a"/></xacro:macro></robot>'
    with pytest.raises(URDFError, match="only defines macros"):
        parse_xacro(text, limits=FAST)


def test_optenv_gives_its_default_the_worker_has_no_environment():
    os.environ["KIN_TEST_SECRET"] = "leaked"
    try:
        model = parse_xacro(HEAD + '<link name="b$(optenv KIN_TEST_SECRET fallback)"/>'
                            '<joint name="j" type="fixed"><parent link="a"/><child link="bfallback"/></joint></robot>',
                            limits=FAST)
    finally:
        del os.environ["KIN_TEST_SECRET"]
    assert "bfallback" in model.links


def test_a_file_outside_is_not_read(tmp_path):
    secret = tmp_path / "secret.xacro"
    secret.write_text('<robot xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="SECRET_LINK"/></robot>')
    with pytest.raises(XacroError, match="reading outside the description is not allowed") as info:
        parse_xacro(HEAD + f'<xacro:include filename="{secret}"/></robot>', limits=FAST)
    assert "SECRET_LINK" not in str(info.value)


def test_str_format_cannot_walk_attributes():
    with pytest.raises(XacroError, match=r"refused: it uses \.format"):
        parse_xacro(HEAD + """<link name="${'x'.format(1)}"/></robot>""", limits=FAST)


def test_macro_calls_are_counted():
    body = '<xacro:macro name="m0"><link name="x"/></xacro:macro>' + "".join(
        f'<xacro:macro name="m{i}"><xacro:m{i - 1}/><xacro:m{i - 1}/></xacro:macro>' for i in range(1, 20)) + "<xacro:m19/>"
    limits = SandboxLimits(cpu_seconds=5, wall_seconds=20, max_macro_calls=500)
    with pytest.raises(ExpansionLimitError, match="more than 500 macro calls"):
        parse_xacro(HEAD + body + "</robot>", limits=limits)


def test_the_output_size_is_capped():
    body = "".join(f'<link name="l{i}_{"x" * 200}"/>' for i in range(200))
    with pytest.raises(ExpansionLimitError, match="over"):
        expand_text(HEAD + body + "</robot>", limits=SandboxLimits(output_bytes=10_000))


def test_packages_are_found_by_package_xml_and_directory(tmp_path):
    (tmp_path / "src" / "my_robot").mkdir(parents=True)
    (tmp_path / "src" / "my_robot" / "package.xml").write_text("<package><name>robot_description</name></package>")
    (tmp_path / "kuka_kr10").mkdir()
    found = find_packages([tmp_path])
    assert found["robot_description"] == (tmp_path / "src" / "my_robot").resolve()
    assert found["kuka_kr10"] == (tmp_path / "kuka_kr10").resolve()
    assert found["kuka_kr10_support"] == found["kuka_kr10"]  # rtb-data's renaming


def test_find_and_package_uris_resolve_inside_the_package_path(tmp_path):
    pkg = tmp_path / "arm_description"
    (pkg / "urdf").mkdir(parents=True)
    (pkg / "package.xml").write_text("<package><name>arm_description</name></package>")
    (pkg / "urdf" / "arm.xacro").write_text(
        '<robot xmlns:xacro="http://www.ros.org/wiki/xacro"><xacro:macro name="arm"><link name="tip"/>'
        '<joint name="j" type="continuous"><parent link="a"/><child link="tip"/></joint></xacro:macro></robot>')
    main = tmp_path / "elsewhere" / "robot.urdf.xacro"
    main.parent.mkdir()
    main.write_text(HEAD + '<xacro:include filename="$(find arm_description)/urdf/arm.xacro"/><xacro:arm/></robot>')
    assert load_xacro(main, package_paths=[tmp_path]).joint_names == ("j",)
    main.write_text(HEAD + '<xacro:include filename="package://arm_description/urdf/arm.xacro"/><xacro:arm/></robot>')
    assert load_xacro(main, package_paths=[tmp_path]).joint_names == ("j",)
    with pytest.raises(XacroError, match="package 'arm_description' is not in the description"):
        load_xacro(main)


RTB_ROBOTS = {  # file under rtbdata/xacro -> dof (the arms rtb-data ships as xacro)
    "unimation_puma560_description/urdf/puma560_robot.urdf.xacro": 6,
    "qut_frankie_description/robots/panda_arm_hand.urdf.xacro": 8,
    "trossen_descriptions/urdf/px100.urdf.xacro": 6,
    "abb_irb140_description/urdf/irb140.xacro": 6,
    "kuka_description/kuka_lbr_iiwa/urdf/lbr_iiwa_14_r820.xacro": 7,
    "kuka_description/kuka_kr6/urdf/kr6r700sixx.xacro": 6,
}


@pytest.mark.skipif(not RTB_XACRO.is_dir(), reason="rtb-data is not installed")
@pytest.mark.parametrize("rel, dof", RTB_ROBOTS.items(), ids=[Path(r).name for r in RTB_ROBOTS])
def test_rtb_data_xacro_robots_expand_and_agree_with_pinocchio(rel, dof, rng):
    model = load_xacro(RTB_XACRO / rel, package_paths=[RTB_XACRO])
    assert model.dof == dof and model.format == "xacro"
    assert crosscheck.compare_fk(model, model.sample_configurations(5, rng)).worst < 1e-9


@pytest.mark.skipif(not ROBOSUITE_PANDA.is_dir(), reason="robosuite is not installed")
def test_robosuite_panda_xacro_matches_the_urdf_it_ships(rng):
    """The panda_arm xacro robosuite ships beside its expanded URDF: the same kinematics."""
    from kinematics import compile_model, load_urdf

    expanded = load_xacro(ROBOSUITE_PANDA / "urdf" / "panda_arm.urdf.xacro", package_paths=[ROBOSUITE_PANDA.parent])
    shipped = load_urdf(ROBOSUITE_PANDA / "urdf" / "panda_arm.urdf")
    assert expanded.joint_names == shipped.joint_names
    Q = shipped.sample_configurations(10, rng)
    links = [link for link in shipped.links if link in expanded.links]
    np.testing.assert_allclose(compile_model(expanded).fk(Q, links), compile_model(shipped).fk(Q, links), atol=1e-9)


EXAMPLE_ROBOT_DATA = SITE / "cmeel.prefix" / "share"
#: why a shipped xacro file makes no robot: each refusal must be one of these (the message says it)
REFUSAL_REASONS = {
    "macros only": "a file that only defines macros makes no robot",
    "package not shipped": "package 'lms1xx' is not in the description",  # ridgeback's SICK mounts
    "pre-namespace <property>": "name 'deg' is not defined",  # kr210: <property> without xacro:, ignored by xacro
    "include of a missing file": "No such file or directory",  # hector quadrotor: includes robots/../urdf/
}


def test_every_xacro_file_shipped_by_rtb_data_and_example_robot_data_loads_or_is_refused_with_a_reason(
        rng, capsys):
    """Every ``.xacro`` of rtb-data and example-robot-data: expanded in the sandbox, then either a
    model that agrees with Pinocchio or a clean refusal whose message says why (never a crash and
    never a model silently missing its macros)."""
    from kinematics.errors import KinematicsError

    trees = [(RTB_XACRO, RTB_XACRO), (EXAMPLE_ROBOT_DATA / "example-robot-data" / "robots", EXAMPLE_ROBOT_DATA)]
    files = [(f, packages) for root, packages in trees if root.is_dir() for f in sorted(root.rglob("*.xacro"))]
    if len(files) < 50:
        pytest.skip("rtb-data or example-robot-data is not installed")
    loaded, refused = [], {reason: [] for reason in REFUSAL_REASONS}
    for path, packages in files:
        try:
            model = load_xacro(path, package_paths=[packages])
        except KinematicsError as exc:
            reason = next((r for r, text in REFUSAL_REASONS.items() if text in str(exc)), None)
            assert reason is not None, f"{path}: refused for an unlisted reason: {exc}"
            refused[reason].append(path.name)
            continue
        assert model.dof >= 1 and model.format == "xacro"
        assert crosscheck.compare_fk(model, model.sample_configurations(3, rng)).worst < 1e-9, path
        loaded.append(path.name)
    with capsys.disabled():
        print(f"\nshipped xacro files: {len(files)}; loaded and agree with Pinocchio: {len(loaded)}; refused: "
              + ", ".join(f"{r} {len(v)}" for r, v in refused.items()))
    assert len(loaded) >= 35 and "puma560_robot.urdf.xacro" in loaded
