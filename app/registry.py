"""The model registry: bundled catalogue + models stored in the data directory.

The data directory is the source of truth for uploaded and DH-built models; what a
process holds in memory is only a cache (``docs/design.md``, "State"). So that
several workers or replicas sharing one directory behave as one service:

* a lookup that misses the cache looks for the file (a model created by another process
  is found on the very next request);
* a cached stored model is served only after a ``stat`` shows its file is still there,
  unchanged (a model deleted by another process is gone everywhere at once);
* listings scan the directory.

Layout (``<data_dir>/models/``), one content file per model plus a small JSON sidecar:

* ``u-<16 hex>.urdf``     an uploaded URDF, byte for byte; the id is the first 16 hex
  digits of its SHA-256, so the same file has the same id on every replica;
* ``dh-<16 hex>.dh.json`` a DH table (the canonical JSON of :func:`kinematics.io.dh_table.table_to_dict`,
  angles in radians, keys sorted); the id hashes that canonical JSON;
* ``poe-<16 hex>.poe.json``, ``axes-<16 hex>.axes.json`` a product-of-exponentials or a
  zero-configuration axes description, stored and hashed the same way (their canonical JSON:
  space screws / every field explicit, radians; :data:`DESCRIPTIONS`);
* ``x-``, ``m-``, ``a-<16 hex>.urdf`` a model read from xacro text, MJCF or a description
  archive (``POST /models``, told apart by content): the file holds the URDF it became
  (expanded or generated); the id hashes what was sent (:func:`upload_id`: the bytes, the
  xacro arguments, the archive entry); the sidecar is required for these and records
  ``upload``: ``format``, ``container``, ``entry``, ``args``, ``warnings`` and the SHA-256 of
  the URDF (``urdf_sha256``, checked on every read);
* ``<id>.meta.json``      ``{"name", "source", "created"}`` (optional; written first), and a
  model's settings: ``collision_pairs`` (``{"allow", "forbid"}``: the link pairs its
  self-collision checks leave out or always make). A bundled model's settings live in a sidecar
  of its id too (it has no content file, so it is never listed as stored).

Writes are atomic (temporary file in the same directory, fsync, ``os.replace``); the
content file is written last and deleted first, so its presence defines the model.
A stored file that is unreadable, not a regular file, or whose content does not hash to its
name, is skipped with a logged warning (a sidecar's fields of the wrong type are ignored). A
write the directory refuses (full, read-only) is a 507 problem naming the cause
(:func:`storage_problem`), and leaves no temporary file or orphan sidecar. Bundled models are
read-only.
"""

from __future__ import annotations

import errno
import hashlib
import json
import logging
import os
import re
import stat as stat_kind
import tempfile
import threading
import time
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from kinematics import api
from kinematics.errors import KinematicsError, UnknownModelError, did_you_mean
from kinematics.io import dh_table as dh
from kinematics.io.catalogue import Catalogue
from kinematics.io.collision_geometry import ArchiveMeshes, vouch_meshes
from kinematics.io.description import load_description
from kinematics.io.urdf import parse_urdf
from kinematics.model.robot import RobotModel

from .errors import ProblemError

log = logging.getLogger("app.registry")


class _KnownUnreadable(ValueError):
    """A stored file already found unreadable (and logged) in its current version."""

#: a temporary file older than this at start-up is a write that was killed half-way (removed)
STALE_TEMPORARY_SECONDS = 3600.0
#: what a model id in a path may look like (no path separators, no "..")
MODEL_ID_PATTERN = r"^[A-Za-z0-9_.-]{1,128}$"
_MODEL_ID = re.compile(MODEL_ID_PATTERN)
#: hex digits of the content hash kept in an id
ID_HASH_DIGITS = 16
UPLOAD_PREFIX, DH_PREFIX = "u-", "dh-"
_UPLOAD_ID = re.compile(rf"^{UPLOAD_PREFIX}[0-9a-f]{{{ID_HASH_DIGITS}}}$")
#: id prefixes of models read from xacro text, MJCF and description archives (stored as their URDF)
UPLOAD_PREFIXES = {"xacro": "x-", "mjcf": "m-", "archive": "a-"}
_CONVERTED_ID = re.compile(rf"^[xma]-[0-9a-f]{{{ID_HASH_DIGITS}}}$")
_DH_ID = re.compile(rf"^{DH_PREFIX}[0-9a-f]{{{ID_HASH_DIGITS}}}$")
URDF_SUFFIX, DH_SUFFIX, META_SUFFIX = ".urdf", ".dh.json", ".meta.json"
#: beside a model read from an archive: its collision meshes (a zip this registry writes)
MESHES_SUFFIX = ".meshes.zip"

SOURCE_UPLOAD, SOURCE_DH = "upload", "dh"
#: DH tables are stored and hashed in radians, so one table written in degrees or radians has one id
DH_CANONICAL_ANGLES = "radians"


@dataclass(frozen=True)
class Description:
    """A kind of model description stored as canonical JSON: ``<prefix><16 hex><suffix>``; the
    model's ``source`` is ``kind`` (:func:`kinematics.usecases.model_from_description` reads it)."""

    kind: str
    prefix: str
    suffix: str

    def matches(self, model_id: str) -> bool:
        return re.fullmatch(rf"{re.escape(self.prefix)}[0-9a-f]{{{ID_HASH_DIGITS}}}", model_id) is not None


#: the stored description kinds, by kind: DH tables, product-of-exponentials, zero-configuration axes
DESCRIPTIONS: dict[str, Description] = {
    "dh": Description("dh", DH_PREFIX, DH_SUFFIX),
    "poe": Description("poe", "poe-", ".poe.json"),
    "axes": Description("axes", "axes-", ".axes.json"),
}
#: sources of stored (deletable) models
STORED_SOURCES = (SOURCE_UPLOAD, *DESCRIPTIONS)


def _description_of(model_id: str) -> Description | None:
    return next((d for d in DESCRIPTIONS.values() if d.matches(model_id)), None)


def _is_stored_id(model_id: str) -> bool:
    return bool(_UPLOAD_ID.match(model_id) or _CONVERTED_ID.match(model_id)) or _description_of(model_id) is not None


@dataclass(frozen=True, eq=False)
class ModelRecord:
    """A registered model and where it comes from."""

    id: str
    name: str
    source: str  # example-robot-data | preset | upload | dh | poe | axes
    model: RobotModel
    created: str | None = None
    dh_table: dict[str, Any] | None = None
    #: (inode, mtime_ns, size) of the content file, then of the sidecar (None when absent): a rename
    #: (a new sidecar) is seen by every worker
    file_key: tuple | None = field(default=None, repr=False)
    description: dict[str, Any] | None = None  # the PoE or axes description (canonical) of such a model
    #: how a model read from xacro, MJCF or an archive was sent: ``container``, ``entry``, ``args``
    upload: dict[str, Any] | None = None

    @property
    def bundled(self) -> bool:
        return self.source not in STORED_SOURCES


@dataclass(frozen=True)
class ModelSummary:
    id: str
    name: str
    source: str
    dof: int | None
    error: str | None = None


def check_model_id(model_id: str) -> None:
    """Raise :class:`UnknownModelError` for ids that cannot name a model (path-like, too long, ...)."""
    if not isinstance(model_id, str) or not _MODEL_ID.match(model_id) or ".." in model_id:
        raise UnknownModelError(f"unknown model {str(model_id)[:140]!r}: ids are 1-128 of A-Z a-z 0-9 _ . -")


def urdf_id(data: bytes) -> str:
    """Id of an uploaded URDF: ``u-`` + the first 16 hex digits of SHA-256 of its bytes."""
    return UPLOAD_PREFIX + hashlib.sha256(data).hexdigest()[:ID_HASH_DIGITS]


def upload_id(kind: str, data: bytes, args: dict[str, str] | None, entry: str | None) -> str:
    """Id of a model read from xacro text, MJCF or an archive (``kind``): ``x-``, ``m-`` or ``a-`` + 16 hex
    digits of the SHA-256 of the canonical JSON of the bytes' SHA-256, the xacro arguments and the entry."""
    key = canonical_json({"sha256": hashlib.sha256(data).hexdigest(), "args": args or {}, "entry": entry})
    return UPLOAD_PREFIXES[kind] + hashlib.sha256(key).hexdigest()[:ID_HASH_DIGITS]


def _text(value: Any) -> str | None:
    """A sidecar's string field, or None when damaged (of another type)."""
    return value if isinstance(value, str) else None


def _shown_upload(upload: dict[str, Any] | None) -> dict[str, Any] | None:
    """What the model info shows of how a model was sent."""
    if upload is None:
        return None
    args = upload.get("args")
    return {"container": _text(upload.get("container")), "entry": _text(upload.get("entry")),
            "args": {str(k): str(v) for k, v in args.items()} if isinstance(args, dict) else {}}


def canonical_json(obj: Any) -> bytes:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False).encode()


def dh_id(canonical: bytes) -> str:
    """Id of a DH-built model: ``dh-`` + the first 16 hex digits of SHA-256 of the canonical table JSON."""
    return DH_PREFIX + hashlib.sha256(canonical).hexdigest()[:ID_HASH_DIGITS]


def description_id(kind: str, canonical: bytes) -> str:
    """Id of a model built from a description: its prefix (``dh-``, ``poe-``, ``axes-``) + the first
    16 hex digits of SHA-256 of the canonical JSON."""
    return DESCRIPTIONS[kind].prefix + hashlib.sha256(canonical).hexdigest()[:ID_HASH_DIGITS]


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


#: errno of a full disk (or quota): 507 Insufficient Storage; any other write failure is a 507 too,
#: titled by its cause (a read-only data directory, permissions)
_FULL = {errno.ENOSPC, errno.EDQUOT}


def storage_problem(model_id: str, action: str, exc: OSError) -> ProblemError:
    """The 507 ``storage-error`` problem of a write to the data directory that failed (``action``:
    "stored", "renamed", "deleted"), naming the cause; logged as an error."""
    cause = exc.strerror or str(exc)
    log.error("cannot write model %s to the data directory (%s): %s", model_id, action, cause)
    if exc.errno in _FULL:
        title = "Insufficient storage"
    elif exc.errno == errno.EROFS:
        title = "Data directory is read-only"
    else:
        title = "Data directory is not writable"
    return ProblemError(507, f"model {model_id} could not be {action}: {cause} (the data directory does not take "
                        "writes; models already stored are still served)", slug="storage-error", title=title)


def _file_key(st: os.stat_result) -> tuple:
    return (st.st_ino, st.st_mtime_ns, st.st_size)


def atomic_write(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically: temp file in the same directory, fsync, rename."""
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=path.suffix, dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    try:  # make the rename durable (best effort: not every file system allows it)
        dfd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)
    except OSError:
        pass


class Registry:
    """Bundled, uploaded and DH-built models, by id (thread-safe)."""

    def __init__(self, catalogue: Catalogue, data_dir: Path, max_links: int):
        self.catalogue = catalogue
        self.data_dir = Path(data_dir)
        self.models_dir = self.data_dir / "models"
        self.models_dir.mkdir(parents=True, exist_ok=True)
        self.max_links = max_links
        self._bundled: dict[str, ModelRecord] = {}
        self._stored: dict[str, ModelRecord] = {}
        #: stored files found unreadable: id -> (file key, reason); logged once per file version
        self._unreadable: dict[str, tuple[Any, str]] = {}
        self._lock = threading.Lock()

    # ------------------------------------------------------------------ start-up
    def load_stored(self) -> int:
        """Load every stored model (start-up); unreadable or foreign files are skipped with a warning.
        Temporary files older than :data:`STALE_TEMPORARY_SECONDS` (a write killed half-way) are removed."""
        self._remove_stale_temporaries()
        count = 0
        for model_id in self._stored_ids():
            try:
                self._load_stored(model_id)
                count += 1
            except _KnownUnreadable:
                pass
            except (OSError, ValueError, KinematicsError) as exc:
                log.warning("skipping stored model %s: %s", model_id, exc)
        return count

    def _remove_stale_temporaries(self) -> None:
        """Remove the ``.tmp-`` files of writes killed half-way (never listed: only their space is at
        stake); a recent one may be another process's write in progress and stays."""
        cutoff = time.time() - STALE_TEMPORARY_SECONDS
        try:
            entries = list(os.scandir(self.models_dir))
        except OSError:
            return
        for entry in entries:
            try:
                if entry.name.startswith(".tmp-") and entry.is_file(follow_symlinks=False) \
                        and entry.stat(follow_symlinks=False).st_mtime < cutoff:
                    os.unlink(entry.path)
                    log.info("removed %s, a temporary file of a write that did not finish", entry.name)
            except OSError:  # gone meanwhile, or a read-only directory
                pass

    # ------------------------------------------------------------------ lookups
    def is_bundled(self, model_id: str) -> bool:
        return model_id in self.catalogue

    def get(self, model_id: str) -> ModelRecord:
        """The record of ``model_id``; raises UnknownModelError (404) or URDFError (bundled file refused)."""
        check_model_id(model_id)
        if model_id in self.catalogue:
            rec = self._bundled.get(model_id)
            if rec is None:
                entry = self.catalogue.entry(model_id)
                model = self.catalogue.get(model_id)
                table = None
                if entry.source == "preset":  # a DH preset: show the table it was built from
                    table = dh.table_to_dict(dh.load_table(entry.path))
                rec = ModelRecord(model_id, model.name, entry.source, model, dh_table=table)
                with self._lock:
                    self._bundled[model_id] = rec
            return rec
        if not _is_stored_id(model_id):
            raise UnknownModelError(f"unknown model {model_id!r}" + self._suggest(model_id))
        try:
            return self._load_stored(model_id)
        except FileNotFoundError:
            with self._lock:
                self._stored.pop(model_id, None)
            raise UnknownModelError(f"unknown model {model_id!r}" + self._suggest(model_id)) from None
        except (OSError, ValueError) as exc:
            if not isinstance(exc, _KnownUnreadable):  # logged once per file version
                log.warning("stored model %s is unreadable: %s", model_id, exc)
            raise UnknownModelError(f"model {model_id!r} is stored but unreadable") from None

    def _suggest(self, model_id: str) -> str:
        """"did you mean" and the valid ids (bundled, then stored), for an unknown id."""
        with self._lock:
            stored = list(self._stored)
        return did_you_mean(model_id, [*self.catalogue.ids(), *stored], "model ids")

    def summaries(self) -> list[ModelSummary]:
        """One summary per model: bundled (catalogue order), then stored (creation order)."""
        out = []
        for model_id in self.catalogue.ids():
            entry = self.catalogue.entry(model_id)
            try:
                rec = self.get(model_id)
                out.append(ModelSummary(model_id, rec.name, rec.source, rec.model.dof))
            except KinematicsError as exc:
                out.append(ModelSummary(model_id, entry.name, entry.source, None, str(exc)))
        stored = []
        for model_id in self._stored_ids():
            try:
                rec = self.get(model_id)
            except KinematicsError:
                continue  # deleted meanwhile, or unreadable (logged)
            stored.append(rec)
        stored.sort(key=lambda r: (r.created or "", r.id))
        out.extend(ModelSummary(r.id, r.name, r.source, r.model.dof) for r in stored)
        return out

    # ------------------------------------------------------------------ writes
    def add_urdf(self, data: bytes, name: str | None = None) -> tuple[ModelRecord, bool]:
        """Register URDF bytes; ``(record, created)``. Raises URDFError for a bad document."""
        model = api.with_geometry_warnings(parse_urdf(data, max_links=self.max_links))
        return self._register(urdf_id(data), model, data, name, SOURCE_UPLOAD)

    def add_upload(self, data: bytes, name: str | None = None, *, args: dict[str, Any] | None = None,
                   entry: str | None = None, expect: str | None = None, **limits: Any) -> tuple[ModelRecord, bool]:
        """Register any description -- URDF, xacro, MJCF, or a zip/gzip/tar archive -- told apart by
        content; ``(record, created)``. A plain URDF is stored as :meth:`add_urdf` stores it; the
        others as the URDF they became. ``limits``: ``xacro_limits``, ``archive_limits``."""
        loaded = load_description(data, args=args, entry=entry, max_links=self.max_links, expect=expect, **limits)
        if loaded.format == "urdf" and loaded.container is None:
            return self._register(urdf_id(data), loaded.model, data, name, SOURCE_UPLOAD)
        kind = "archive" if loaded.container else loaded.format
        model_id = upload_id(kind, data, dict(loaded.args or {}), loaded.entry)
        model = loaded.model
        urdf = model.urdf.encode("utf-8")
        if loaded.meshes is not None and loaded.meshes.files:  # kept so that every process reads the same meshes
            try:
                atomic_write(self._meshes_path(model_id), loaded.meshes.to_bytes())
            except OSError as exc:
                raise storage_problem(model_id, "stored", exc) from None
        upload = {"format": loaded.format, "container": loaded.container, "entry": loaded.entry,
                  "args": dict(loaded.args or {}), "warnings": list(model.warnings),
                  "urdf_sha256": hashlib.sha256(urdf).hexdigest(), "source_sha256": hashlib.sha256(data).hexdigest()}
        return self._register(model_id, model, urdf, name, SOURCE_UPLOAD, upload=upload)

    def add_dh(self, table_dict: dict[str, Any], name: str | None = None) -> tuple[ModelRecord, bool]:
        """Register a model built from a DH table (the JSON of ``POST /models/dh``); ``(record, created)``."""
        return self.add_description("dh", table_dict, name)

    def add_description(self, kind: str, description: dict[str, Any], name: str | None = None
                        ) -> tuple[ModelRecord, bool]:
        """Register a model built from a description of ``kind`` (``dh``, ``poe``, ``axes``: the JSON of
        ``POST /models/<kind>``), stored as its canonical JSON; ``(record, created)``."""
        model, canonical_dict = api.model_from_description(kind, description, max_links=self.max_links)
        canonical = canonical_json(canonical_dict)
        stored = json.loads(canonical)
        return self._register(description_id(kind, canonical), model, canonical, name, kind,
                              stored if kind == "dh" else None, stored if kind != "dh" else None)

    def _register(self, model_id: str, model: RobotModel, content: bytes, name: str | None, source: str,
                  table: dict[str, Any] | None = None, description: dict[str, Any] | None = None,
                  upload: dict[str, Any] | None = None) -> tuple[ModelRecord, bool]:
        """``(record, created)``: the model already stored under ``model_id``, or ``model`` stored now.

        A new record is built from the model the caller parsed, not read and parsed again from disk.
        """
        try:
            return self.get(model_id), False
        except UnknownModelError:
            pass
        meta = {"id": model_id, "name": name or model.name, "source": source, "created": _now()}
        if upload is not None:
            meta["upload"] = upload
        self._store(model_id, meta, content)
        key = self._record_key(model_id, os.stat(self._content_path(model_id)))
        rec = ModelRecord(model_id, meta["name"], source, model, meta["created"], table, key, description,
                          _shown_upload(upload))
        with self._lock:
            self._stored[model_id] = rec
        return rec, True

    def _store(self, model_id: str, meta: dict[str, Any], content: bytes) -> None:
        """Sidecar, then content, each atomically. A disk that is full or read-only answers a 507
        problem (nothing partial is left: a content file exists whole or not at all, and a sidecar
        written for a content file that could not be is removed again)."""
        meta_path = self._meta_path(model_id)
        had_meta = meta_path.exists()
        try:
            atomic_write(meta_path, canonical_json(meta))
            try:
                atomic_write(self._content_path(model_id), content)
            except OSError:
                if not had_meta and not self._content_path(model_id).exists():  # not another writer's
                    try:
                        os.unlink(meta_path)
                    except OSError:
                        pass
                raise
        except OSError as exc:
            raise storage_problem(model_id, "stored", exc) from None

    def rename(self, model_id: str, name: str) -> ModelRecord:
        """Give a stored model a new display name (its sidecar is rewritten atomically; the id, a
        content hash, does not change). Raises UnknownModelError for bundled or unknown ids."""
        rec = self.get(model_id)
        if rec.bundled:
            raise UnknownModelError(f"model {model_id!r} is bundled; its name cannot change")
        meta = self._read_meta(model_id) or {"id": model_id, "source": rec.source, "created": rec.created}
        meta["name"] = name
        self._store_meta(model_id, meta)
        renamed = replace(rec, name=name,
                          file_key=self._record_key(model_id, os.stat(self._content_path(model_id))))
        with self._lock:
            self._stored[model_id] = renamed
        return renamed

    def _store_meta(self, model_id: str, meta: dict[str, Any], action: str = "renamed") -> None:
        try:
            atomic_write(self._meta_path(model_id), canonical_json(meta))
        except OSError as exc:
            raise storage_problem(model_id, action, exc) from None

    def collision_pairs(self, model_id: str) -> dict[str, Any] | None:
        """The model's stored ``{"allow": [[a, b], ...], "forbid": [...]}`` (None: none set).
        Read from the sidecar on every call, so a change by another worker is seen at once."""
        self.get(model_id)
        pairs = self._read_meta(model_id).get("collision_pairs")
        return pairs if isinstance(pairs, dict) else None

    def set_collision_pairs(self, model_id: str, pairs: dict[str, Any] | None) -> None:
        """Store (None or empty lists: clear) the model's collision pairs in its sidecar; the caller
        has checked the link names."""
        rec = self.get(model_id)
        meta = self._read_meta(model_id) or ({} if rec.bundled else
                                             {"id": model_id, "name": rec.name, "source": rec.source,
                                              "created": rec.created})
        if pairs and any(pairs.values()):
            meta["collision_pairs"] = pairs
        else:
            meta.pop("collision_pairs", None)
        self._store_meta(model_id, meta, "given its collision pairs")
        if not rec.bundled:  # the record's key includes the sidecar's: the same model under the new key
            kept = replace(rec, file_key=self._record_key(model_id, os.stat(self._content_path(model_id))))
            with self._lock:
                self._stored[model_id] = kept

    def _record_key(self, model_id: str, content: os.stat_result) -> tuple:
        try:
            meta = _file_key(os.stat(self._meta_path(model_id)))
        except FileNotFoundError:
            meta = None
        return (*_file_key(content), meta)

    def delete(self, model_id: str) -> None:
        """Remove a stored model (content file first, then its sidecar). Bundled ids are refused by the caller."""
        check_model_id(model_id)
        if not _is_stored_id(model_id):
            raise UnknownModelError(f"unknown model {model_id!r}")
        with self._lock:
            self._stored.pop(model_id, None)
        try:
            os.unlink(self._content_path(model_id))
        except FileNotFoundError:
            raise UnknownModelError(f"unknown model {model_id!r}") from None
        except OSError as exc:  # a read-only data directory: the model stays, and says so
            raise storage_problem(model_id, "deleted", exc) from None
        for path in (self._meta_path(model_id), self._meshes_path(model_id)):
            try:
                os.unlink(path)
            except OSError:  # gone, or not removable: an orphan sidecar (or meshes file) is never listed
                pass

    # ------------------------------------------------------------------ files
    def _content_path(self, model_id: str) -> Path:
        kind = _description_of(model_id)
        suffix = URDF_SUFFIX if kind is None else kind.suffix
        return self.models_dir / f"{model_id}{suffix}"

    def _meta_path(self, model_id: str) -> Path:
        return self.models_dir / f"{model_id}{META_SUFFIX}"

    def _meshes_path(self, model_id: str) -> Path:
        """The collision meshes of a model read from an archive (written by this registry only)."""
        return self.models_dir / f"{model_id}{MESHES_SUFFIX}"

    def _stored_ids(self) -> list[str]:
        ids = []
        try:
            names = os.listdir(self.models_dir)
        except FileNotFoundError:
            return []
        for fname in sorted(names):
            if fname.endswith(URDF_SUFFIX) and (_UPLOAD_ID.match(fname[: -len(URDF_SUFFIX)])
                                                or _CONVERTED_ID.match(fname[: -len(URDF_SUFFIX)])):
                ids.append(fname[: -len(URDF_SUFFIX)])
            for kind in DESCRIPTIONS.values():
                if fname.endswith(kind.suffix) and kind.matches(fname[: -len(kind.suffix)]):
                    ids.append(fname[: -len(kind.suffix)])
        return ids

    def _load_stored(self, model_id: str) -> ModelRecord:
        """The stored model, from the cache if its file is unchanged, else read from disk.

        Raises FileNotFoundError (gone), ValueError (corrupt or foreign), KinematicsError.
        """
        path = self._content_path(model_id)
        st = os.stat(path)
        key = self._record_key(model_id, st)
        cached = self._stored.get(model_id)
        if cached is not None and cached.file_key == key:
            return cached
        known_bad = self._unreadable.get(model_id)
        if known_bad is not None and known_bad[0] == key:  # same bad file: refused again, not re-read
            raise _KnownUnreadable(known_bad[1])
        try:
            if not stat_kind.S_ISREG(st.st_mode):  # a directory, a FIFO (reading it would block), a device
                raise ValueError(f"{path.name}: not a regular file")
            return self._read_stored(model_id, path, st, key)
        except ValueError as exc:
            with self._lock:
                self._unreadable[model_id] = (key, str(exc))
            raise

    def _read_stored(self, model_id: str, path: Path, st: os.stat_result, key) -> ModelRecord:
        data = path.read_bytes()
        meta = self._read_meta(model_id)
        created = _text(meta.get("created")) or datetime.fromtimestamp(st.st_mtime, timezone.utc).isoformat(
            timespec="seconds")
        table = description = upload = None
        if _CONVERTED_ID.match(model_id):
            upload = meta.get("upload")
            if not isinstance(upload, dict) or not isinstance(upload.get("urdf_sha256"), str):
                raise ValueError(f"{path.name}: its sidecar (format, arguments, URDF hash) is missing or unreadable")
            if hashlib.sha256(data).hexdigest() != upload["urdf_sha256"]:
                raise ValueError(f"{path.name}: content does not hash to its sidecar's urdf_sha256 (corrupt or foreign file)")
            try:
                model = parse_urdf(data, max_links=self.max_links)
            except KinematicsError as exc:
                raise ValueError(f"{path.name}: {exc}") from None
            warnings = upload.get("warnings")
            model = replace(model, format=str(upload.get("format") or "urdf"),
                            warnings=tuple(str(w) for w in warnings) if isinstance(warnings, list) else model.warnings)
            try:
                meshes = self._meshes_path(model_id).read_bytes()
            except FileNotFoundError:
                pass
            else:
                try:
                    vouch_meshes(model, ArchiveMeshes.from_bytes(meshes))
                except (KinematicsError, ValueError, KeyError, OSError) as exc:
                    log.warning("ignoring the unreadable meshes of %s: %s", model_id, exc)
            source = SOURCE_UPLOAD
        elif model_id.startswith(UPLOAD_PREFIX):
            if urdf_id(data) != model_id:
                raise ValueError(f"{path.name}: content does not hash to its id (corrupt or foreign file)")
            try:
                model = api.with_geometry_warnings(parse_urdf(data, max_links=self.max_links))
            except KinematicsError as exc:
                raise ValueError(f"{path.name}: {exc}") from None
            source = SOURCE_UPLOAD
        else:
            kind = _description_of(model_id)
            try:
                stored = json.loads(data)
                if not isinstance(stored, dict):
                    raise ValueError("not a JSON object")
                model, canonical = api.model_from_description(kind.kind, stored, max_links=self.max_links)
                if description_id(kind.kind, canonical_json(canonical)) != model_id:
                    raise ValueError("content does not hash to its id (corrupt or foreign file)")
            except (ValueError, KinematicsError) as exc:
                raise ValueError(f"{path.name}: {exc}") from None
            source = kind.kind
            if kind.kind == "dh":
                table = stored
            else:
                description = stored
        name = meta.get("name") if isinstance(meta.get("name"), str) else model.name
        rec = ModelRecord(model_id, name, source, model, created, table, key, description, _shown_upload(upload))
        with self._lock:
            self._stored[model_id] = rec
        return rec

    def _read_meta(self, model_id: str) -> dict[str, Any]:
        try:
            path = self._meta_path(model_id)
            if not stat_kind.S_ISREG(os.stat(path).st_mode):  # a FIFO would block the read
                raise ValueError(f"{path.name}: not a regular file")
            meta = json.loads(path.read_bytes())
            return meta if isinstance(meta, dict) else {}
        except FileNotFoundError:
            return {}
        except (OSError, ValueError) as exc:
            log.warning("ignoring unreadable sidecar of %s: %s", model_id, exc)
            return {}
