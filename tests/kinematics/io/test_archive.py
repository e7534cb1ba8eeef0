"""Description archives: a real ROS package zipped and tarred (meshes in it never extracted),
the entry chosen or named, xacro arguments; the hostile corpus holds the refusals."""

from __future__ import annotations

import io
import os
import tarfile
import zipfile
from pathlib import Path

import numpy as np
import pytest

from kinematics.errors import ArchiveError, ArchiveTooLargeError, DescriptionFormatError
from kinematics.io.archive import ArchiveLimits, archive_kind, extract, member_path
from kinematics.io.description import load_description
from kinematics.verify import pinocchio as crosscheck

SITE = Path(np.__file__).resolve().parents[1]
PANDA = SITE / "robosuite" / "models" / "assets" / "bullet_data" / "panda_description"
TWO_LINK = (Path(__file__).resolve().parents[2] / "fixtures" / "descriptions" / "two_link.urdf.xacro").read_bytes()

needs_panda = pytest.mark.skipif(not PANDA.is_dir(), reason="robosuite is not installed")


def _files(root: Path):
    for here, _, names in os.walk(root):
        for n in sorted(names):
            p = Path(here) / n
            yield p, str(p.relative_to(root.parent))


@pytest.fixture(scope="module")
def panda_zip() -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        for path, name in _files(PANDA):
            zf.write(path, name)
    return buf.getvalue()


@pytest.fixture(scope="module")
def panda_tgz() -> bytes:
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz") as tf:
        tf.add(PANDA, arcname=PANDA.name)
    return buf.getvalue()


@needs_panda
def test_meshes_are_never_extracted(panda_zip, tmp_path):
    written = extract(panda_zip, tmp_path)
    assert "panda_description/package.xml" in written and "panda_description/urdf/panda_arm.urdf.xacro" in written
    assert not [w for w in written if w.endswith((".stl", ".dae", ".obj", ".png"))]
    on_disk = {str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*") if p.is_file()}
    assert on_disk == set(written)


@needs_panda
@pytest.mark.parametrize("kind", ["zip", "tgz"])
def test_a_ros_package_archive_loads_its_named_entry(kind, panda_zip, panda_tgz, rng):
    data = panda_zip if kind == "zip" else panda_tgz
    assert archive_kind(data) == ("zip" if kind == "zip" else "gzip")
    with pytest.raises(ArchiveError, match=r"holds 6 robot descriptions .*name one with 'entry'"):
        load_description(data)
    loaded = load_description(data, entry="panda_description/urdf/panda_arm.urdf.xacro")
    assert loaded.format == "xacro" and loaded.container == archive_kind(data)
    assert loaded.entry == "panda_description/urdf/panda_arm.urdf.xacro" and loaded.model.dof == 7
    assert crosscheck.compare_fk(loaded.model, loaded.model.sample_configurations(5, rng)).worst < 1e-9
    urdf = load_description(data, entry="panda_description/urdf/hand.urdf")
    assert urdf.format == "urdf" and urdf.model.dof == 1  # the hand's second finger mimics the first


def _zip(members: dict[str, bytes]) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    return buf.getvalue()


def test_the_only_description_is_the_entry_and_args_reach_it():
    data = _zip({"arm/package.xml": b"<package><name>arm</name></package>", "arm/urdf/arm.urdf.xacro": TWO_LINK,
                 "arm/urdf/macros.xacro": b'<robot xmlns:xacro="http://www.ros.org/wiki/xacro"><xacro:macro name="m"/></robot>',
                 "arm/config/limits.yaml": b"a: 1\n"})
    loaded = load_description(data, args={"length": 2})
    assert loaded.entry == "arm/urdf/arm.urdf.xacro" and loaded.args == {"length": "2"}
    np.testing.assert_allclose(loaded.model.joint_map["lower_joint"].origin[:3, 3], [0, 0, 2])


def test_an_entry_that_is_not_in_the_archive_lists_those_that_are():
    data = _zip({"arm/urdf/arm.urdf.xacro": TWO_LINK})
    with pytest.raises(ArchiveError, match=r"entry 'arm/robot.urdf' is not .*arm/urdf/arm.urdf.xacro"):
        load_description(data, entry="arm/robot.urdf")
    with pytest.raises(ArchiveError, match="leaves the archive"):
        load_description(data, entry="../arm/urdf/arm.urdf.xacro")


def test_yaml_of_the_archive_is_readable_by_the_expansion():
    xacro = (b'<robot name="y" xmlns:xacro="http://www.ros.org/wiki/xacro">'
             b'<xacro:property name="c" value="${xacro.load_yaml(\'$(find arm)/config/arm.yaml\')}"/>'
             b'<link name="a"/><link name="b"/><joint name="j" type="prismatic"><parent link="a"/><child link="b"/>'
             b'<origin xyz="0 0 ${c.height}"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint></robot>')
    data = _zip({"arm/package.xml": b"<package><name>arm</name></package>", "arm/robot.urdf.xacro": xacro,
                 "arm/config/arm.yaml": b"height: 0.25\n"})
    model = load_description(data).model
    np.testing.assert_allclose(model.joint_map["j"].origin[:3, 3], [0, 0, 0.25])


def test_lying_sizes_are_caught_while_reading():
    """A zip member whose header understates its size: refused, not extracted in full."""
    good = _zip({"a/robot.urdf": b"<robot name='x'><link name='a'/></robot>" + b" " * 5000})
    assert load_description(good).model.links == ("a",)
    with pytest.raises(ArchiveTooLargeError):
        load_description(good, archive_limits=ArchiveLimits(max_bytes=1000))


@pytest.mark.parametrize("name, message", [
    ("a/../../x.urdf", "leaves the archive"), ("/x.urdf", "absolute path"), ("C:/x.urdf", "names a drive"),
    ("a\\x.urdf", "backslash"), ("a/\x00.urdf", "NUL"),
])
def test_hostile_member_names(name, message):
    with pytest.raises(ArchiveError, match=message):
        member_path(name)


def test_plain_names_are_normalised():
    assert str(member_path("./a//b/./c.urdf")) == "a/b/c.urdf" and member_path("./") is None


def test_xacro_arguments_for_a_plain_urdf_are_refused():
    with pytest.raises(DescriptionFormatError, match="xacro arguments were given, but the body is URDF"):
        load_description(b"<robot name='x'><link name='a'/></robot>", args={"a": 1})
