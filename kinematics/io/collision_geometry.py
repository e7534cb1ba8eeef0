"""Collision geometry: the URDF's ``<collision>`` elements of every link, read from the model's own text.

A link's geometry is a tuple of :class:`Shape` (one per ``<collision>`` element, document order),
each placed in the link frame by ``origin`` (``T_link_shape``, 4x4):

* primitives, always: ``box`` (``size = (x, y, z)``, full edge lengths), ``cylinder``
  (``(radius, length)``, axis ``z``, centred), ``sphere`` (``(radius,)``), ``capsule``
  (``(radius, length)``, the segment's length along ``z``; a common extension of URDF);
* meshes (``size`` is the ``scale``, ``(sx, sy, sz)``), opened only where a :class:`MeshSource`
  vouches for them:

  - :class:`PackageMeshes` -- the installed catalogue packages (``example-robot-data``): a
    ``package://`` name resolved inside the packages' directory, a regular file, no symlink
    leaving it; the shape carries the file's ``path``;
  - :class:`ArchiveMeshes` -- the mesh members of an uploaded archive, already read into memory
    with size caps (:func:`kinematics.io.archive.read_meshes`); the shape carries the ``data``
    bytes and never a path.

  Without a source (a plain uploaded URDF) or when the name is absolute, ``file://``, leaves its
  package with ``..``, or is not there, the mesh is never opened: the link keeps its other shapes
  and :attr:`CollisionGeometry.warnings` names the mesh.

Nothing here parses mesh bytes (the narrow phase, :mod:`kinematics.algorithms.collision`, builds
coal's BVH from them with ``trimesh``) -- this module only decides what may be read.

>>> from kinematics.io.urdf import parse_urdf
>>> m = parse_urdf('''<robot name="r"><link name="a"><collision><origin xyz="0 0 0.5"/>
...   <geometry><sphere radius="0.1"/></geometry></collision>
...   <collision><geometry><mesh filename="/etc/passwd"/></geometry></collision></link></robot>''')
>>> g = collision_geometry(m)
>>> g.links, g.shapes["a"][0].kind, g.shapes["a"][0].size
(('a',), 'sphere', (0.1,))
>>> g.warnings[0]
"link 'a': mesh '/etc/passwd' not opened (a plain URDF's meshes are never read; upload an archive with the mesh inside)"
"""

from __future__ import annotations

import hashlib
import math
import os
import posixpath
import stat
import threading
import weakref
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np

from ..errors import URDFError
from ..model.robot import RobotModel, frozen_array
from ..spatial.rotations import rpy_to_matrix
from .urdf import read_xml

#: mesh formats read (by suffix, case-insensitive)
MESH_SUFFIXES = (".stl", ".obj", ".dae")
#: the largest mesh file read, bytes (catalogue and archive alike)
MAX_MESH_BYTES = 32 << 20
#: the most triangles of one mesh, and of one model's collision geometry
MAX_MESH_TRIANGLES = 500_000
MAX_MODEL_TRIANGLES = 4_000_000
#: the largest primitive dimension accepted (m); beyond it the shape is skipped with a warning
MAX_PRIMITIVE_SIZE = 1e3


@dataclass(frozen=True, eq=False)
class Shape:
    """One ``<collision>`` element: ``kind``, ``origin`` (``T_link_shape``), ``size`` (see the module
    doc), and for a mesh its ``source`` (the file name the URDF wrote) with either ``path`` (an
    installed catalogue file) or ``data`` (bytes from an uploaded archive) and the ``format``
    (``stl``, ``obj``, ``dae``)."""

    kind: str
    origin: np.ndarray
    size: tuple[float, ...]
    source: str | None = None
    path: Path | None = None
    data: bytes | None = field(default=None, repr=False)
    format: str | None = None

    def fingerprint(self) -> str:
        """A text that changes when the shape does (kind, placement, size, mesh content)."""
        parts = [self.kind, ",".join(f"{x:.17g}" for x in self.origin.ravel()), ",".join(f"{x:.17g}" for x in self.size)]
        if self.data is not None:
            parts.append(hashlib.sha256(self.data).hexdigest())
        elif self.path is not None:
            st = self.path.stat()
            parts.append(f"{self.path}:{st.st_size}:{st.st_mtime_ns}")
        return "|".join(parts)


@dataclass(frozen=True, eq=False)
class CollisionGeometry:
    """Per link (``model.links`` order, only links with at least one shape) its shapes; the
    warnings of what was skipped and why; ``source`` names where meshes came from."""

    shapes: Mapping[str, tuple[Shape, ...]]
    warnings: tuple[str, ...] = ()
    source: str = "none"

    @property
    def links(self) -> tuple[str, ...]:
        return tuple(self.shapes)

    def fingerprint(self) -> str:
        """SHA-256 (hex) of every shape of every link: the key of derived data (the matrix cache)."""
        h = hashlib.sha256()
        for link, shapes in self.shapes.items():
            h.update(link.encode() + b"\0")
            for s in shapes:
                h.update(s.fingerprint().encode() + b"\0")
        return h.hexdigest()


class MeshSource:
    """Where meshes may be read from; :meth:`resolve` gives ``(path, data)`` (one of them set) or
    raises :class:`LookupError` with the reason the mesh is not read."""

    name = "none"

    def resolve(self, filename: str) -> tuple[Path | None, bytes | None]:
        raise LookupError("a plain URDF's meshes are never read; upload an archive with the mesh inside")


_sources: "weakref.WeakKeyDictionary[RobotModel, MeshSource]" = weakref.WeakKeyDictionary()
_sources_lock = threading.Lock()


def vouch_meshes(model: RobotModel, source: MeshSource) -> RobotModel:
    """Record that ``model``'s meshes may be read from ``source`` (the catalogue does it for the
    models it loads, the description reader for an archive's model); the model, for chaining.
    Trust goes with the model object, never with its text: the same URDF uploaded as a plain
    file gets no source."""
    with _sources_lock:
        _sources[model] = source
    return model


def mesh_source(model: RobotModel) -> MeshSource | None:
    """The source vouched for ``model`` (see :func:`vouch_meshes`), or None."""
    with _sources_lock:
        return _sources.get(model)


def _relative(name: str) -> str:
    """``name`` as a normalised relative posix path; LookupError if absolute, a URL or leaving with ``..``."""
    if "\x00" in name or "\\" in name:
        raise LookupError("the name has a NUL or a backslash")
    if name.startswith("/") or (len(name) >= 2 and name[1] == ":"):
        raise LookupError("absolute paths are never opened")
    if "://" in name:
        raise LookupError(f"{name.split('://', 1)[0]}:// names are not read")
    parts = [p for p in name.split("/") if p not in ("", ".")]
    if not parts or ".." in parts:
        raise LookupError("the name leaves its package ('..')")
    return "/".join(parts)


def _package(name: str) -> tuple[str, str]:
    """``package://pkg/rest`` -> ``(pkg, rest)`` (rest checked by :func:`_relative`)."""
    if not name.startswith("package://"):
        if "://" in name or name.startswith("/"):
            raise LookupError("only package:// names are read" if "://" in name else "absolute paths are never opened")
        raise LookupError("a relative name has no package")
    pkg, _, rest = name[len("package://"):].lstrip("/").partition("/")  # package:///pkg: as ROS tools read it
    if not pkg or pkg in (".", ".."):
        raise LookupError("the package:// name has no package")
    return pkg, _relative(rest)


class PackageMeshes(MeshSource):
    """Meshes of the installed catalogue: ``package://example-robot-data/robots/<rest>`` and
    ``package://<pkg>/<rest>`` resolve to ``root/<rest>`` and ``root/<pkg>/<rest>``, where ``root``
    is example-robot-data's ``robots`` directory. A file that is not a regular file inside
    ``root`` (after following links) or is larger than :data:`MAX_MESH_BYTES` is not read."""

    name = "catalogue"

    def __init__(self, root: os.PathLike | str):
        self.root = Path(root).resolve()

    def resolve(self, filename: str) -> tuple[Path | None, bytes | None]:
        pkg, rest = _package(filename)
        if pkg == "example-robot-data":
            head, _, tail = rest.partition("/")
            if head != "robots" or not tail:
                raise LookupError("not under example-robot-data's robots/")
            candidate = self.root / tail
        else:
            candidate = self.root / pkg / rest
        real = candidate.resolve()
        if not str(real).startswith(str(self.root) + os.sep):
            raise LookupError("the file leaves the installed packages")
        try:
            st = real.stat()
        except OSError:
            raise LookupError("no such file in the installed packages") from None
        if not stat.S_ISREG(st.st_mode):
            raise LookupError("not a regular file")
        if st.st_size > MAX_MESH_BYTES:
            raise LookupError(f"the file is larger than {MAX_MESH_BYTES} bytes")
        return real, None


class ArchiveMeshes(MeshSource):
    """Mesh members of an uploaded archive, in memory: ``files`` maps member paths to bytes,
    ``packages`` maps ROS package names to their directory in the archive (``package.xml``),
    ``base`` is the directory of the description's entry (relative names resolve from it)."""

    name = "archive"

    def __init__(self, files: Mapping[str, bytes], packages: Mapping[str, str] | None = None, base: str = "",
                 extracted_root: str | None = None):
        self.files = dict(files)
        self.packages = dict(packages or {})
        self.base = base.strip("/")
        #: where the archive was extracted while its xacro was expanded (``$(find pkg)`` wrote it)
        self.extracted_root = extracted_root.rstrip("/") + "/" if extracted_root else None

    def resolve(self, filename: str) -> tuple[Path | None, bytes | None]:
        if self.extracted_root:
            for prefix in (self.extracted_root, "file://" + self.extracted_root):
                if filename.startswith(prefix):
                    member = _relative(filename[len(prefix):])
                    break
            else:
                member = None
            if member is not None:
                data = self.files.get(member)
                if data is None:
                    raise LookupError("the archive has no such mesh member (or it was over the size caps)")
                return None, data
        if filename.startswith("package://"):
            pkg, rest = _package(filename)
            if pkg not in self.packages:
                raise LookupError(f"the archive has no package {pkg!r}")
            member = posixpath.join(self.packages[pkg], rest) if self.packages[pkg] else rest
        else:  # relative to the entry's directory; '..' may climb within the archive, never out of it
            if "\x00" in filename or "\\" in filename or "://" in filename:
                raise LookupError("the name has a NUL, a backslash or a URL scheme")
            if filename.startswith("/") or (len(filename) >= 2 and filename[1] == ":"):
                raise LookupError("absolute paths are never opened")
            member = posixpath.normpath(posixpath.join(self.base, filename))
            if member == ".." or member.startswith("../") or member.startswith("/"):
                raise LookupError("the name leaves the archive ('..')")
        data = self.files.get(member)
        if data is None:
            raise LookupError("the archive has no such mesh member (or it was over the size caps)")
        return None, data

    #: the member of :meth:`to_bytes` that holds the packages, the base and the extraction root
    MANIFEST = "kinematics-meshes.json"

    def to_bytes(self) -> bytes:
        """This source as a zip (stored, members sorted; a manifest beside the meshes): what a
        registry keeps next to an archive's model so that another process reads the same meshes."""
        import io
        import json
        import zipfile

        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as zf:
            manifest = {"packages": self.packages, "base": self.base,
                        "extracted_root": self.extracted_root.rstrip("/") if self.extracted_root else None}
            zf.writestr(zipfile.ZipInfo(self.MANIFEST, (1980, 1, 1, 0, 0, 0)), json.dumps(manifest, sort_keys=True))
            for name in sorted(self.files):
                zf.writestr(zipfile.ZipInfo(name, (1980, 1, 1, 0, 0, 0)), self.files[name])
        return buf.getvalue()

    @classmethod
    def from_bytes(cls, data: bytes) -> "ArchiveMeshes":
        """The source :meth:`to_bytes` wrote (read with the archive checks and caps)."""
        import io
        import json
        import zipfile

        from .archive import read_meshes

        files, _ = read_meshes(data)
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            manifest = json.loads(zf.read(cls.MANIFEST)[:1 << 20])
        return cls(files, manifest.get("packages") or {}, manifest.get("base") or "", manifest.get("extracted_root"))


def model_meshes(model: RobotModel) -> MeshSource:
    """Where ``model``'s meshes may be read from: the source vouched for it (or for the model a
    floating-base form was made from), else nowhere (:class:`MeshSource`, which reads nothing)."""
    source = mesh_source(model)
    if source is None and model.base_model is not None:  # a floating-base form shares its model's meshes
        source = mesh_source(model.base_model)
    return source if source is not None else MeshSource()


def resolve_mesh(source: MeshSource, filename: str) -> tuple[Path | None, bytes | None, str]:
    """``(path, data, format)`` of the mesh ``filename`` names, as ``source`` allows it (one of
    ``path``, ``data`` set; ``format`` ``stl``, ``obj`` or ``dae``). Raises :class:`LookupError`
    saying why it is not read: a format other than :data:`MESH_SUFFIXES`, a name the source
    refuses, bytes over :data:`MAX_MESH_BYTES`. Opens nothing (a catalogue file is only stat'ed).

    >>> resolve_mesh(MeshSource(), "package://pkg/arm.stl")
    Traceback (most recent call last):
    ...
    LookupError: a plain URDF's meshes are never read; upload an archive with the mesh inside
    """
    suffix = posixpath.splitext(filename)[1].lower()
    if suffix not in MESH_SUFFIXES:
        if source.name == "none":  # a plain upload says why first: nothing is read
            source.resolve(filename)
        raise LookupError(f"format {suffix or 'unknown'}; only "
                          f"{', '.join(s[1:].upper() for s in MESH_SUFFIXES)} are read")
    path, data = source.resolve(filename)
    if data is not None and len(data) > MAX_MESH_BYTES:
        raise LookupError(f"larger than {MAX_MESH_BYTES} bytes")
    return path, data, suffix[1:]


def attribute_numbers(text: str | None, n: int, default: tuple[float, ...], what: str) -> tuple[float, ...]:
    if text is None:
        return default
    parts = text.split()
    if len(parts) != n:
        raise ValueError(f"{what} needs {n} numbers, got {text!r}")
    values = tuple(float(p) for p in parts)
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"{what} is not finite: {text!r}")
    return values


def _origin(el) -> np.ndarray:
    o = el.find("origin")
    T = np.eye(4)
    if o is not None:
        T[:3, :3] = rpy_to_matrix(attribute_numbers(o.get("rpy"), 3, (0.0, 0.0, 0.0), "<origin rpy>"))
        T[:3, 3] = attribute_numbers(o.get("xyz"), 3, (0.0, 0.0, 0.0), "<origin xyz>")
    return frozen_array(T)


def _primitive(kind: str, g) -> tuple[float, ...]:
    if kind == "box":
        size = attribute_numbers(g.get("size"), 3, None, "<box size>")  # type: ignore[arg-type]
        if size is None:
            raise ValueError("<box> has no size")
    elif kind == "sphere":
        size = (float(g.get("radius")),)
    else:  # cylinder, capsule
        size = (float(g.get("radius")), float(g.get("length")))
    if not all(math.isfinite(s) and 0.0 <= s <= MAX_PRIMITIVE_SIZE for s in size):
        raise ValueError(f"<{kind}> dimensions {size} are not in [0, {MAX_PRIMITIVE_SIZE:g}] m")
    return size


def geometry_elements(root, links, tag: str, primitives: tuple[str, ...], unknown: str, warnings: list[str],
                      max_scale: float | None = None):
    """Read every ``<tag>`` (``collision`` or ``visual``) of a ``<link>`` of ``root`` named in
    ``links``, in document order: yield ``(link name, element, kind, origin, size, filename, scale)``
    -- ``kind`` the tag of its ``<geometry>`` child, ``origin`` (4, 4) ``T_link_element``, ``size``
    a primitive's dimensions (``kind`` in ``primitives``; None for a mesh), ``filename`` and
    ``scale`` a ``<mesh>``'s (None for a primitive). An element that cannot be read is skipped
    and named in ``warnings`` (any other kind: "<tag> <kind> ``unknown``"; a mesh scale beyond
    ``max_scale`` counts as unreadable)."""
    known = set(links)
    for link in root.findall("link"):
        lname = link.get("name")
        if lname not in known:
            continue
        for el in link.findall(tag):
            geom = el.find("geometry")
            shape_el = geom[0] if geom is not None and len(geom) else None
            kind = shape_el.tag if shape_el is not None and isinstance(shape_el.tag, str) else None
            try:
                origin = _origin(el)
                if kind in primitives:
                    yield lname, el, kind, origin, _primitive(kind, shape_el), None, None
                    continue
                if kind != "mesh":
                    warnings.append(f"link {lname!r}: <{tag}> " + (f"<{kind}>" if kind else "without geometry")
                                    + " " + unknown)
                    continue
                filename, scale = mesh_reference(shape_el)
                if max_scale is not None and not all(math.isfinite(s) and abs(s) <= max_scale for s in scale):
                    raise ValueError(f"<mesh scale> {scale} is out of range")
            except (ValueError, TypeError) as exc:
                warnings.append(f"link {lname!r}: <{tag}> skipped ({exc})")
                continue
            yield lname, el, kind, origin, None, filename, scale


def mesh_reference(shape_el) -> tuple[str, tuple[float, float, float]]:
    """The ``filename`` (stripped) and ``scale`` (default 1, 1, 1) of a ``<mesh>`` element;
    ValueError for a scale that is not three numbers."""
    filename = (shape_el.get("filename") or "").strip()
    return filename, attribute_numbers(shape_el.get("scale"), 3, (1.0, 1.0, 1.0), "<mesh scale>")  # type: ignore[return-value]


def collision_geometry(model: RobotModel, meshes: MeshSource | None = None) -> CollisionGeometry:
    """The collision shapes of ``model`` (see the module doc); ``meshes`` says where meshes may be
    read from (None: the source vouched for the model, else nowhere -- a plain upload). Never
    raises for a bad element: it is skipped and named in ``warnings``."""
    source = meshes if meshes is not None else model_meshes(model)
    try:
        root = read_xml(model.urdf.encode("utf-8"))
    except URDFError:
        return CollisionGeometry({}, ("the model's URDF text could not be re-read for its collision geometry",))
    per_link: dict[str, list[Shape]] = {}
    warnings: list[str] = []
    for lname, _, kind, origin, size, filename, scale in geometry_elements(
            root, model.links, "collision", ("box", "cylinder", "sphere", "capsule"),
            "is not a shape this product reads; skipped", warnings):
        if size is not None:
            per_link.setdefault(lname, []).append(Shape(kind, origin, size))
            continue
        try:
            path, data, fmt = resolve_mesh(source, filename)
        except LookupError as why:
            warnings.append(f"link {lname!r}: mesh {filename!r} not {'read' if 'larger' in str(why) else 'opened'} ({why})")
            continue
        per_link.setdefault(lname, []).append(Shape("mesh", origin, scale, filename, path, data, fmt))
    ordered = {name: tuple(per_link[name]) for name in model.links if name in per_link}
    return CollisionGeometry(ordered, tuple(warnings), source.name)


def with_geometry_warnings(model: RobotModel) -> RobotModel:
    """``model`` with what its collision geometry leaves out (a mesh a plain upload names, a shape
    that cannot be read) added to its ``warnings`` -- a new model, vouched for like the old; the
    same model when nothing is left out. Reads no mesh bytes (only names are resolved)."""
    from dataclasses import replace

    extra = [w for w in collision_geometry(model).warnings if w not in model.warnings]
    if not extra:
        return model
    out = replace(model, warnings=tuple(model.warnings) + tuple(extra))
    source = mesh_source(model)
    return vouch_meshes(out, source) if source is not None else out
