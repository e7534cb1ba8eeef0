"""Hostile description archives of the corpus, built on demand (``generate:`` items of
``manifest.yaml``): path traversal, absolute paths, links and devices, zip and gzip bombs,
includes that leave the archive. Each is a few kilobytes."""

from __future__ import annotations

import functools
import gzip
import io
import tarfile
import zipfile

ROBOT = (b'<?xml version="1.0"?><robot name="arc"><link name="a"/><link name="b"/>'
         b'<joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
         b'<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>')
PACKAGE_XML = b"<package format='2'><name>arc_description</name><version>1.0.0</version></package>"
XACRO_HEAD = b'<?xml version="1.0"?><robot name="arc" xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="a"/>'

#: limits of the "small" app (tests/app/test_hostile_input.py::SMALL_LIMITS) that the bombs are built against
SMALL_ARCHIVE_BYTES = 65536


def _zip(members: list[tuple], compression=zipfile.ZIP_DEFLATED) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression) as zf:
        for name, data, *mode in members:
            info = zipfile.ZipInfo(name)
            info.compress_type = compression
            if mode:
                info.external_attr = mode[0] << 16
            zf.writestr(info, data)
    return buf.getvalue()


def _tar(members: list[tarfile.TarInfo | tuple], compress: bool = True) -> bytes:
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz" if compress else "w") as tf:
        for m in members:
            if isinstance(m, tarfile.TarInfo):
                tf.addfile(m)
            else:
                name, data = m
                info = tarfile.TarInfo(name)
                info.size = len(data)
                tf.addfile(info, io.BytesIO(data))
    return buf.getvalue()


def _link(name: str, target: str, kind: bytes) -> tarfile.TarInfo:
    info = tarfile.TarInfo(name)
    info.type = kind
    info.linkname = target
    return info


def _gzip_bomb() -> bytes:
    """A tar.gz whose one (mesh) member is 16 x the small app's archive size of zeros."""
    size = 64 * SMALL_ARCHIVE_BYTES
    info = tarfile.TarInfo("pkg/meshes/huge.stl")
    info.size = size
    raw = io.BytesIO()
    with tarfile.open(fileobj=raw, mode="w") as tf:
        tf.addfile(info, io.BytesIO(bytes(size)))
    return gzip.compress(raw.getvalue(), compresslevel=9)


def _device() -> tarfile.TarInfo:
    info = tarfile.TarInfo("pkg/urdf/robot.urdf")
    info.type = tarfile.CHRTYPE
    info.devmajor, info.devminor = 1, 3
    return info


BUILDERS = {
    "zip_traversal": lambda: _zip([("pkg/package.xml", PACKAGE_XML), ("../../robot.urdf", ROBOT)]),
    "zip_absolute": lambda: _zip([("/tmp/robot.urdf", ROBOT)]),
    "zip_symlink": lambda: _zip([("pkg/urdf/robot.urdf", b"/etc/passwd", 0o120777)]),
    "zip_bomb": lambda: _zip([("pkg/urdf/robot.urdf", ROBOT + b" " * (16 * SMALL_ARCHIVE_BYTES))]),
    "zip_too_many_members": lambda: _zip([(f"pkg/f{i}.yaml", b"") for i in range(60)]),
    "zip_not_an_archive": lambda: b"PK\x03\x04" + b"\x00" * 100,
    "zip_no_description": lambda: _zip([("pkg/package.xml", PACKAGE_XML), ("pkg/meshes/a.stl", b"solid")]),
    "zip_two_descriptions": lambda: _zip([("a/robot.urdf", ROBOT), ("b/robot.urdf", ROBOT)]),
    "zip_include_passwd": lambda: _zip([("pkg/package.xml", PACKAGE_XML), (
        "pkg/robot.urdf.xacro", XACRO_HEAD + b'<xacro:include filename="/etc/passwd"/></robot>')]),
    "zip_find_escape": lambda: _zip([("pkg/package.xml", PACKAGE_XML), (
        "pkg/robot.urdf.xacro",
        XACRO_HEAD + b'<xacro:include filename="$(find arc_description)/../../../../../etc/passwd"/></robot>')]),
    "zip_include_symlinked_dir": lambda: _zip([("pkg/etc", b"/etc", 0o120777), (
        "pkg/robot.urdf.xacro", XACRO_HEAD + b'<xacro:include filename="etc/passwd"/></robot>')]),
    "tar_traversal": lambda: _tar([("pkg/../../robot.urdf", ROBOT)]),
    "tar_absolute": lambda: _tar([("/etc/robot.urdf", ROBOT)]),
    "tar_symlink": lambda: _tar([_link("pkg/urdf/robot.urdf", "/etc/passwd", tarfile.SYMTYPE)]),
    "tar_hardlink": lambda: _tar([_link("pkg/urdf/robot.urdf", "/etc/passwd", tarfile.LNKTYPE)]),
    "tar_device": lambda: _tar([_device()]),
    "gzip_bomb": _gzip_bomb,
    "gzip_truncated": lambda: _tar([("pkg/robot.urdf", ROBOT)])[:40],
}


@functools.lru_cache(maxsize=None)
def build(name: str) -> bytes:
    """The bytes of the generated corpus item ``name``."""
    return BUILDERS[name]()


def media_type(name: str) -> str:
    return "application/zip" if name.startswith("zip_") else "application/gzip"
