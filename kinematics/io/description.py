"""Any robot description a user brings -> :class:`~kinematics.model.RobotModel`, told apart by content.

:func:`detect` reads the bytes, never the file name: a zip, gzip or tar archive by its first
bytes; otherwise XML (read with :mod:`defusedxml`) whose root is ``<mujoco>`` (MJCF) or
``<robot>`` -- xacro when it uses the xacro namespace or ``${...}`` expressions, else URDF.
Anything else is refused (:class:`~kinematics.errors.DescriptionFormatError`); XML with
another root goes to the URDF reader, whose refusal names that root.

:func:`load_description` then reads it whole or not at all:

* ``urdf`` -- :func:`~kinematics.io.urdf.parse_urdf`;
* ``xacro`` -- expanded in the sandbox (:mod:`kinematics.io.xacro`), alone in a temporary directory;
* ``mjcf`` -- :func:`~kinematics.io.mjcf.parse_mjcf` (no file is opened);
* ``zip``/``gzip``/``tar`` -- checked and its description files extracted
  (:mod:`kinematics.io.archive`) into a temporary directory; its ROS packages (``package.xml``)
  are what ``$(find pkg)`` resolves; the entry is ``entry`` (a path inside the archive) or the
  only description in it (every ``.urdf``, ``.xacro`` and ``.xml`` whose root is a named
  ``<robot>`` or a ``<mujoco>``). The model's ``format`` is the entry's.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass, replace
from pathlib import Path, PurePosixPath
from typing import Mapping

from ..errors import ArchiveError, DescriptionFormatError, URDFError
from ..model.robot import RobotModel
from . import archive as archives
from . import xacro as xacros
from .collision_geometry import ArchiveMeshes, vouch_meshes, with_geometry_warnings
from .mjcf import parse_mjcf
from .urdf import DEFAULT_MAX_LINKS, parse_urdf, read_xml, xacro_use

#: every format :func:`detect` names
FORMATS = ("urdf", "xacro", "mjcf", "zip", "gzip", "tar")
ARCHIVES = ("zip", "gzip", "tar")
#: suffixes of the files an archive's entry may be
ENTRY_SUFFIXES = (".urdf", ".xacro", ".xml")


def detect(data: bytes) -> str:
    """The format of a description, by content: one of :data:`FORMATS`. Bytes that are neither an
    archive nor ``<mujoco>`` or xacro are ``urdf``: the URDF reader refuses them, saying why."""
    kind = archives.archive_kind(data)
    if kind is not None:
        return kind
    try:
        root = read_xml(data)
    except URDFError:
        return "urdf"
    if root.tag == "mujoco":
        return "mjcf"
    if root.tag == "robot" and xacro_use(root) is not None:
        return "xacro"
    return "urdf"


def _looks_like_xml(data: bytes) -> bool:
    head = data[:1024].lstrip(b"\xef\xbb\xbf \t\r\n")
    return not head or head.startswith((b"<", b"\xff\xfe", b"\xfe\xff"))


@dataclass(frozen=True)
class Loaded:
    """A model and how it was read: ``format`` (of the entry), ``container`` (the archive kind, or
    None), ``entry`` (the path inside the archive), ``args`` (xacro arguments used)."""

    model: RobotModel
    format: str
    container: str | None = None
    entry: str | None = None
    args: Mapping[str, str] | None = None
    #: an archive's mesh members (the only meshes an upload's collision geometry may read), else None
    meshes: "ArchiveMeshes | None" = None
    #: what reading the archive's meshes left out
    mesh_warnings: tuple[str, ...] = ()


def load_description(data: bytes, *, args: Mapping[str, object] | None = None, entry: str | None = None,
                     max_links: int = DEFAULT_MAX_LINKS, xacro_limits: xacros.SandboxLimits = xacros.DEFAULT_LIMITS,
                     archive_limits: archives.ArchiveLimits = archives.DEFAULT_ARCHIVE_LIMITS,
                     expect: str | None = None) -> Loaded:
    """Read any description (see the module doc). ``expect`` (a format, or ``archive``) refuses
    content of another kind; ``args`` are xacro arguments; ``entry`` picks a file of an archive."""
    fmt = detect(data)
    if expect is not None and not (fmt == expect or (expect == "archive" and fmt in ARCHIVES)
                                   or (expect == "xml" and fmt not in ARCHIVES)):
        raise DescriptionFormatError(f"the content is {_named(fmt)}, not {_named(expect)} as its type says")
    checked = xacros.check_args(args)
    if fmt not in ARCHIVES:
        if entry is not None:
            raise DescriptionFormatError("'entry' names a file of an archive; the body is a single document")
        if checked and fmt != "xacro":
            raise DescriptionFormatError(f"xacro arguments were given, but the body is {_named(fmt)}, not xacro")
    if fmt == "urdf":
        try:
            return Loaded(with_geometry_warnings(parse_urdf(data, max_links=max_links)), "urdf")
        except URDFError as exc:
            if _looks_like_xml(data):
                raise
            raise DescriptionFormatError(f"the body is not a robot description: neither XML (URDF, xacro, MJCF) "
                                         f"nor a zip, gzip or tar archive ({exc})") from None
    if fmt == "mjcf":
        return Loaded(with_geometry_warnings(parse_mjcf(data, max_links=max_links)), "mjcf")
    if fmt == "xacro":
        model = xacros.parse_xacro(data, args=checked, limits=xacro_limits, max_links=max_links)
        return Loaded(with_geometry_warnings(model), "xacro", args=checked)
    with tempfile.TemporaryDirectory(prefix="kin-archive-") as tmp:
        root = Path(tmp)
        files = archives.extract(data, root, limits=archive_limits)
        chosen = _entry(root, files, entry)
        entry_data = (root / chosen).read_bytes()
        kind = detect(entry_data)
        if kind == "mjcf":
            if checked:
                raise DescriptionFormatError(f"xacro arguments were given, but {chosen!r} is MJCF")
            model = parse_mjcf(entry_data, base_dir=(root / chosen).parent, max_links=max_links)
        elif kind in ("urdf", "xacro"):
            if kind == "urdf" and not checked:
                model = parse_urdf(entry_data, max_links=max_links)
            else:  # xacro, or a URDF given arguments: the sandbox, reading only the extracted files
                packages = xacros.find_packages([root])
                expansion = xacros.expand(root / chosen, roots=[root], packages=packages, args=checked,
                                          limits=xacro_limits)
                model = xacros.with_format(xacros._parse_expanded(expansion, max_links), "xacro")
                kind = "xacro"
        else:
            raise ArchiveError(f"archive member {chosen!r} is {_named(kind)}, not a robot description")
        mesh_files, mesh_warnings = archives.read_meshes(data, limits=archive_limits)
        packages = {name: path.resolve().relative_to(root.resolve()).as_posix()
                    for name, path in xacros.find_packages([root]).items()
                    if path.resolve().is_relative_to(root.resolve())}
        meshes = ArchiveMeshes(mesh_files, {k: ("" if v == "." else v) for k, v in packages.items()},
                               base="" if "/" not in chosen else PurePosixPath(chosen).parent.as_posix(),
                               extracted_root=str(root))
        model = with_geometry_warnings(vouch_meshes(model, meshes))
        return Loaded(model, kind, container=fmt, entry=chosen, args=checked, meshes=meshes,
                      mesh_warnings=tuple(mesh_warnings))


def _named(fmt: str) -> str:
    return {"urdf": "URDF", "xacro": "xacro", "mjcf": "MJCF", "zip": "a zip archive", "gzip": "a gzip archive",
            "tar": "a tar archive", "archive": "an archive", "xml": "an XML document"}.get(fmt, fmt)


def _entry(root: Path, files: list[str], entry: str | None) -> str:
    if entry is not None:
        rel = archives.member_path(entry)
        if rel is None or str(rel) not in files:
            shown = ", ".join(_candidates(root, files)[:10]) or "none"
            raise ArchiveError(f"entry {entry!r} is not a description file of the archive (descriptions: {shown})")
        return str(rel)
    found = _candidates(root, files)
    if len(found) == 1:
        return found[0]
    if not found:
        raise ArchiveError("the archive holds no robot description (no .urdf, .xacro or .xml file whose root is a "
                           "named <robot> or <mujoco>)")
    shown = ", ".join(found[:10]) + (f" and {len(found) - 10} more" if len(found) > 10 else "")
    raise ArchiveError(f"the archive holds {len(found)} robot descriptions ({shown}): name one with 'entry'")


def _candidates(root: Path, files: list[str]) -> list[str]:
    out = []
    for name in files:
        p = PurePosixPath(name)
        if not p.name.lower().endswith(ENTRY_SUFFIXES) or p.name == "package.xml":
            continue
        try:
            el = read_xml((root / name).read_bytes())
        except URDFError:
            continue
        if (el.tag == "robot" and el.get("name") and _has_content(el)) or el.tag == "mujoco":
            out.append(name)
    return out


def _has_content(el) -> bool:
    """A <robot> that makes links or calls macros (a file of macro definitions only is no robot)."""
    for child in el:
        tag = child.tag if isinstance(child.tag, str) else ""
        local = tag.split("}", 1)[-1]
        if local in ("link", "joint"):
            return True
        if tag.startswith("{") and local not in ("macro", "property", "arg", "include"):
            return True  # a macro call
    return False


def model_with_format(loaded: Loaded) -> RobotModel:
    """The loaded model with its ``format`` set (what the registry stores and serves)."""
    if loaded.model.format == loaded.format:
        return loaded.model
    model = replace(loaded.model, format=loaded.format)
    return vouch_meshes(model, loaded.meshes) if loaded.meshes is not None else model
