"""Description archives (``.zip``, ``.tar.gz``, ``.tar``): checked, then the text files extracted.

An archive holds one or more ROS packages (``package.xml``) with their xacro, URDF, YAML and
mesh files. :func:`extract` writes only the files a description is read from (by suffix:
:data:`EXTRACTED_SUFFIXES`) into a fresh directory -- meshes and images are never written,
so never opened -- and refuses, naming the member:

* a name that is absolute, has a drive, a backslash or a NUL, or a ``..`` component
  (path traversal), and a name given twice;
* symbolic and hard links, devices, FIFOs; encrypted zip members;
* more than ``max_members`` members, more than ``max_bytes`` of extracted files (zip: summed
  from the central directory *before* anything is extracted, then enforced while reading,
  as sizes can lie), and -- gzip -- a stream that decompresses to more than
  ``max_stream_bytes`` (a tar of zeros compresses a thousandfold).

:func:`read_meshes` reads the mesh members (STL, OBJ, DAE) into memory -- never onto disk --
with the same refusals and per-mesh and per-archive byte caps (:class:`MeshLimits`): the only
meshes an upload's collision geometry may use (:mod:`kinematics.io.collision_geometry`).
"""

from __future__ import annotations

import gzip
import io
import os
import stat
import tarfile
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from ..errors import ArchiveError, ArchiveTooLargeError

MIB = 1 << 20
#: files extracted (everything a xacro or URDF can include or load); meshes and images are not
EXTRACTED_SUFFIXES = (".xacro", ".urdf", ".xml", ".yaml", ".yml", ".srdf", ".gazebo", ".trans",
                      ".transmission", ".macro", ".inc")


@dataclass(frozen=True)
class ArchiveLimits:
    """Bounds on one archive: members, bytes of extracted files, decompressed stream bytes."""

    max_members: int = 20_000
    max_bytes: int = 64 * MIB
    max_stream_bytes: int = 512 * MIB


DEFAULT_ARCHIVE_LIMITS = ArchiveLimits()


def archive_kind(data: bytes) -> str | None:
    """``zip``, ``gzip`` (a gzip-compressed tar) or ``tar`` by the first bytes, else None."""
    if data[:4] in (b"PK\x03\x04", b"PK\x05\x06"):
        return "zip"
    if data[:2] == b"\x1f\x8b":
        return "gzip"
    if len(data) >= 262 and data[257:262] == b"ustar":
        return "tar"
    return None


def member_path(name: str) -> PurePosixPath | None:
    """The relative path of an archive member, or None for a directory entry; ArchiveError if hostile."""
    shown = repr(name[:200])
    if "\x00" in name:
        raise ArchiveError(f"archive member {shown} has a NUL in its name")
    if "\\" in name:
        raise ArchiveError(f"archive member {shown} uses a backslash in its path")
    if name.startswith("/"):
        raise ArchiveError(f"archive member {shown} has an absolute path")
    if len(name) >= 2 and name[1] == ":":
        raise ArchiveError(f"archive member {shown} names a drive")
    parts = [p for p in name.split("/") if p not in ("", ".")]
    if ".." in parts:
        raise ArchiveError(f"archive member {shown} leaves the archive ('..' in its path)")
    if not parts:
        return None
    return PurePosixPath(*parts)


def _wanted(path: PurePosixPath) -> bool:
    return path.name.lower().endswith(EXTRACTED_SUFFIXES)


class _CappedReader(io.RawIOBase):
    """A file object over ``inner`` that refuses to give more than ``cap`` bytes in total."""

    def __init__(self, inner, cap: int):
        self.inner, self.cap, self.count = inner, cap, 0

    def readable(self) -> bool:
        return True

    def readinto(self, buf) -> int:
        chunk = self.inner.read(min(len(buf), 1 * MIB))
        self.count += len(chunk)
        if self.count > self.cap:
            raise ArchiveTooLargeError(f"the archive decompresses to more than {self.cap} bytes (a compression bomb?)")
        buf[: len(chunk)] = chunk
        return len(chunk)


def _write(dest: Path, rel: PurePosixPath, data: bytes, written: set) -> None:
    if rel in written:
        raise ArchiveError(f"archive member {str(rel)!r} appears twice")
    written.add(rel)
    target = dest.joinpath(*rel.parts)
    if not str(target.resolve()).startswith(str(dest.resolve()) + os.sep):  # belt and braces
        raise ArchiveError(f"archive member {str(rel)!r} leaves the archive")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o644)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
    except OSError as exc:
        raise ArchiveError(f"archive member {str(rel)!r} cannot be extracted: {exc.strerror or exc}") from None


_ZIP_READ_ERRORS = (zipfile.BadZipFile, zlib.error, EOFError, ValueError, NotImplementedError, RuntimeError)


def _zip_files(data: bytes, limits: ArchiveLimits, wanted) -> tuple[zipfile.ZipFile, list]:
    """The open zip and its members ``(info, rel)`` that are files whose path ``wanted(rel)``
    accepts, after the checks every member gets (count, names, links, devices)."""
    try:
        zf = zipfile.ZipFile(io.BytesIO(data))
        infos = zf.infolist()
    except (zipfile.BadZipFile, zipfile.LargeZipFile, ValueError, EOFError) as exc:
        raise ArchiveError(f"the body is not a readable zip archive: {exc}") from None
    if len(infos) > limits.max_members:
        raise ArchiveTooLargeError(f"the archive has {len(infos)} members; the limit is {limits.max_members}")
    files = []
    for info in infos:
        rel = member_path(info.filename)
        kind = stat.S_IFMT((info.external_attr >> 16) & 0xFFFF)  # unix file type (0: none recorded)
        if kind == stat.S_IFLNK:
            raise ArchiveError(f"archive member {info.filename!r} is a symbolic link; links are refused")
        if kind not in (0, stat.S_IFREG, stat.S_IFDIR):
            raise ArchiveError(f"archive member {info.filename!r} is not a regular file")
        if rel is not None and not info.is_dir() and wanted(rel):
            files.append((info, rel))
    return zf, files


def _zip_read(zf: zipfile.ZipFile, info: zipfile.ZipInfo, n: int) -> bytes:
    """At most ``n`` bytes of the member ``info`` (an unreadable one: :class:`ArchiveError` naming it)."""
    try:
        with zf.open(info) as fh:
            return fh.read(n)
    except _ZIP_READ_ERRORS as exc:
        raise ArchiveError(f"archive member {info.filename!r} cannot be read: {exc}") from None


def _each_tar_file(data: bytes, limits: ArchiveLimits, compressed: bool, wanted, visit) -> None:
    """``visit(member, rel, read)`` for each member of a tar stream that is a file whose path
    ``wanted(rel)`` accepts (``read(n)``: at most n bytes of it), in stream order, after the checks
    every member gets (count, names, links, devices, the decompressed-stream cap)."""
    raw = io.BytesIO(data)
    stream = _CappedReader(gzip.GzipFile(fileobj=raw, mode="rb") if compressed else raw, limits.max_stream_bytes)
    members = 0
    try:
        with tarfile.open(fileobj=io.BufferedReader(stream, 1 * MIB), mode="r|") as tf:
            for member in tf:
                members += 1
                if members > limits.max_members:
                    raise ArchiveTooLargeError(f"the archive has more than {limits.max_members} members")
                rel = member_path(member.name)
                if member.issym() or member.islnk():
                    raise ArchiveError(f"archive member {member.name!r} is a {'symbolic' if member.issym() else 'hard'} "
                                       "link; links are refused")
                if member.isdir():
                    continue
                if not member.isfile():
                    raise ArchiveError(f"archive member {member.name!r} is not a regular file (a device or FIFO)")
                if rel is None or not wanted(rel):
                    continue
                fh = tf.extractfile(member)
                visit(member, rel, fh.read if fh else (lambda n: b""))
    except (tarfile.TarError, gzip.BadGzipFile, zlib.error, EOFError, OSError) as exc:
        if isinstance(exc, ArchiveError):
            raise
        raise ArchiveError(f"the body is not a readable {'gzip-compressed ' if compressed else ''}tar archive: {exc}") from None


def _extract_zip(data: bytes, dest: Path, limits: ArchiveLimits) -> list[str]:
    zf, files = _zip_files(data, limits, _wanted)
    total = 0
    for info, _ in files:
        if info.flag_bits & 0x1:
            raise ArchiveError(f"archive member {info.filename!r} is encrypted")
        total += info.file_size
        if total > limits.max_bytes:
            raise ArchiveTooLargeError(
                f"the archive's description files uncompress to more than {limits.max_bytes} bytes "
                f"(at member {info.filename!r}); nothing was extracted")
    written: set = set()
    for info, rel in files:
        content = _zip_read(zf, info, info.file_size + 1)
        if len(content) > info.file_size:
            raise ArchiveTooLargeError(f"archive member {info.filename!r} is larger than its header says")
        _write(dest, rel, content, written)
    return sorted(str(r) for r in written)


def _extract_tar(data: bytes, dest: Path, limits: ArchiveLimits, compressed: bool) -> list[str]:
    written: set = set()
    total = 0

    def visit(member, rel, read) -> None:
        nonlocal total
        total += member.size
        if total > limits.max_bytes:
            raise ArchiveTooLargeError(f"the archive's description files are more than {limits.max_bytes} bytes "
                                       f"(at member {member.name!r})")
        _write(dest, rel, read(member.size), written)

    _each_tar_file(data, limits, compressed, _wanted, visit)
    return sorted(str(r) for r in written)


def extract(data: bytes, dest: os.PathLike | str, *, limits: ArchiveLimits = DEFAULT_ARCHIVE_LIMITS) -> list[str]:
    """Check the archive ``data`` and extract its description files into the directory ``dest``;
    the relative paths written, sorted. Meshes and images are never written."""
    dest = Path(dest)
    kind = archive_kind(data)
    if kind == "zip":
        return _extract_zip(data, dest, limits)
    if kind in ("gzip", "tar"):
        return _extract_tar(data, dest, limits, compressed=kind == "gzip")
    raise ArchiveError("the body is not a zip, gzip or tar archive")


#: mesh members read into memory by :func:`read_meshes` (never written to disk)
MESH_SUFFIXES = (".stl", ".obj", ".dae")


@dataclass(frozen=True)
class MeshLimits:
    """Bounds on the meshes read from one archive: bytes of one mesh, bytes of all of them."""

    max_mesh_bytes: int = 32 * MIB
    max_total_bytes: int = 128 * MIB


DEFAULT_MESH_LIMITS = MeshLimits()


def _is_mesh(path: PurePosixPath) -> bool:
    return path.name.lower().endswith(MESH_SUFFIXES)


def read_meshes(data: bytes, *, limits: ArchiveLimits = DEFAULT_ARCHIVE_LIMITS,
                mesh_limits: MeshLimits = DEFAULT_MESH_LIMITS) -> tuple[dict[str, bytes], list[str]]:
    """The mesh members (:data:`MESH_SUFFIXES`) of the archive ``data``, in memory: ``({member path:
    bytes}, warnings)``. Same refusals as :func:`extract` (hostile names, links, devices, members,
    the decompressed-stream cap); a mesh over ``max_mesh_bytes`` -- by its header and while
    reading, as sizes can lie -- or past ``max_total_bytes`` is left out with a warning."""
    kind = archive_kind(data)
    out: dict[str, bytes] = {}
    warnings: list[str] = []
    total = 0

    def take(rel: PurePosixPath, size: int, read) -> None:
        nonlocal total
        name = str(rel)
        if size > mesh_limits.max_mesh_bytes:
            warnings.append(f"archive mesh {name!r} is larger than {mesh_limits.max_mesh_bytes} bytes; not read")
            return
        if total + size > mesh_limits.max_total_bytes:
            warnings.append(f"archive mesh {name!r} is past the {mesh_limits.max_total_bytes} bytes of meshes "
                            "read from one archive; not read")
            return
        content = read(size + 1)
        if len(content) > size:
            warnings.append(f"archive mesh {name!r} is larger than its header says; not read")
            return
        if name in out:
            raise ArchiveError(f"archive member {name!r} appears twice")
        total += len(content)
        out[name] = content

    if kind == "zip":
        zf, files = _zip_files(data, limits, _is_mesh)
        for info, rel in files:
            if not info.flag_bits & 0x1:  # an encrypted mesh is passed over
                take(rel, info.file_size, lambda n, info=info: _zip_read(zf, info, n))
        return out, warnings
    if kind not in ("gzip", "tar"):
        raise ArchiveError("the body is not a zip, gzip or tar archive")
    _each_tar_file(data, limits, kind == "gzip", _is_mesh, lambda member, rel, read: take(rel, member.size, read))
    return out, warnings
