"""What was sent, told by content (never by file name): URDF, xacro, MJCF, zip, gzip, tar."""

from __future__ import annotations

import io
import tarfile

import pytest

from kinematics.errors import DescriptionFormatError, URDFError
from kinematics.io.description import detect, load_description

from tests.corpus import archives
from tests.paths import CORPUS, FIXTURES

URDF = (CORPUS / "fixture_arm.urdf").read_bytes()
XACRO = (FIXTURES / "descriptions" / "two_link.urdf.xacro").read_bytes()
MJCF = b'<mujoco model="m"><worldbody><body name="a"><joint name="j" range="-1 1"/></body></worldbody></mujoco>'


def _tar() -> bytes:
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w") as tf:
        info = tarfile.TarInfo("pkg/robot.urdf")
        info.size = len(URDF)
        tf.addfile(info, io.BytesIO(URDF))
    return buf.getvalue()


@pytest.mark.parametrize("data, fmt", [
    (URDF, "urdf"), (XACRO, "xacro"), (MJCF, "mjcf"), (archives.ROBOT, "urdf"),
    (archives.build("zip_two_descriptions"), "zip"), (archives.build("tar_traversal"), "gzip"), (_tar(), "tar"),
    (b'<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="a"/></robot>', "urdf"),
    (b'<robot name="r"><link name="${prefix}a"/></robot>', "xacro"),
    (b"\xef\xbb\xbf" + MJCF, "mjcf"),
])
def test_detect_by_content(data, fmt):
    assert detect(data) == fmt


@pytest.mark.parametrize("data, fmt", [(URDF, "urdf"), (XACRO, "xacro"), (MJCF, "mjcf"), (_tar(), "urdf")])
def test_each_kind_loads_and_says_what_it_was(data, fmt):
    loaded = load_description(data)
    assert loaded.format == fmt and loaded.model.format == fmt
    assert loaded.container == ("tar" if data[257:262] == b"ustar" else None)


@pytest.mark.parametrize("data, message", [
    (b"\x89PNG\r\n\x1a\n" + bytes(40), "not a robot description"),
    (b"just some text", "not a robot description"),
    (b"<sdf version='1.9'><model name='m'/></sdf>", "root element is <sdf>"),
    (b"<robot name='r'><link name='a'/>", "not well-formed"),
])
def test_anything_else_is_refused_never_read_in_part(data, message):
    with pytest.raises(URDFError, match=message):
        load_description(data)


def test_the_declared_kind_must_match_the_content():
    with pytest.raises(DescriptionFormatError, match="the content is URDF, not an archive"):
        load_description(URDF, expect="archive")
    with pytest.raises(DescriptionFormatError, match="'entry' names a file of an archive"):
        load_description(URDF, entry="robot.urdf")
