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
* ``<id>.meta.json``      ``{"name", "source", "created"}`` (optional; written first).

Writes are atomic (temporary file in the same directory, fsync, ``os.replace``); the
content file is written last and deleted first, so its presence defines the model.
A stored file that is unreadable, or whose content does not hash to its name, is skipped
with a logged warning. Bundled models are read-only.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import re
import tempfile
import threading
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from kinematics.errors import KinematicsError, UnknownModelError
from kinematics.io import dh_table as dh
from kinematics.io.catalogue import Catalogue
from kinematics.io.urdf import parse_urdf
from kinematics.model.robot import RobotModel

from .errors import ProblemError

log = logging.getLogger("app.registry")


class _KnownUnreadable(ValueError):
    """A stored file already found unreadable (and logged) in its current version."""

#: what a model id in a path may look like (no path separators, no "..")
MODEL_ID_PATTERN = r"^[A-Za-z0-9_.-]{1,128}$"
_MODEL_ID = re.compile(MODEL_ID_PATTERN)
#: hex digits of the content hash kept in an id
ID_HASH_DIGITS = 16
UPLOAD_PREFIX, DH_PREFIX = "u-", "dh-"
_UPLOAD_ID = re.compile(rf"^{UPLOAD_PREFIX}[0-9a-f]{{{ID_HASH_DIGITS}}}$")
_DH_ID = re.compile(rf"^{DH_PREFIX}[0-9a-f]{{{ID_HASH_DIGITS}}}$")
URDF_SUFFIX, DH_SUFFIX, META_SUFFIX = ".urdf", ".dh.json", ".meta.json"

SOURCE_UPLOAD, SOURCE_DH = "upload", "dh"
#: DH tables are stored and hashed in radians, so one table written in degrees or radians has one id
DH_CANONICAL_ANGLES = "radians"


@dataclass(frozen=True, eq=False)
class ModelRecord:
    """A registered model and where it comes from."""

    id: str
    name: str
    source: str  # example-robot-data | preset | upload | dh
    model: RobotModel
    created: str | None = None
    dh_table: dict[str, Any] | None = None
    file_key: tuple | None = field(default=None, repr=False)  # (inode, mtime_ns, size) of the content file

    @property
    def bundled(self) -> bool:
        return self.source not in (SOURCE_UPLOAD, SOURCE_DH)


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


def canonical_json(obj: Any) -> bytes:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False).encode()


def dh_id(canonical: bytes) -> str:
    """Id of a DH-built model: ``dh-`` + the first 16 hex digits of SHA-256 of the canonical table JSON."""
    return DH_PREFIX + hashlib.sha256(canonical).hexdigest()[:ID_HASH_DIGITS]


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


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
        """Load every stored model (start-up); unreadable or foreign files are skipped with a warning."""
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
        if not (_UPLOAD_ID.match(model_id) or _DH_ID.match(model_id)):
            raise UnknownModelError(f"unknown model {model_id!r}")
        try:
            return self._load_stored(model_id)
        except FileNotFoundError:
            with self._lock:
                self._stored.pop(model_id, None)
            raise UnknownModelError(f"unknown model {model_id!r}") from None
        except (OSError, ValueError) as exc:
            if not isinstance(exc, _KnownUnreadable):  # logged once per file version
                log.warning("stored model %s is unreadable: %s", model_id, exc)
            raise UnknownModelError(f"model {model_id!r} is stored but unreadable") from None

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
        model = parse_urdf(data, max_links=self.max_links)
        return self._register(urdf_id(data), model, data, name, SOURCE_UPLOAD)

    def add_dh(self, table_dict: dict[str, Any], name: str | None = None) -> tuple[ModelRecord, bool]:
        """Register a model built from a DH table (the JSON of ``POST /models/dh``); ``(record, created)``."""
        table = dh.table_from_dict(table_dict)
        canonical = canonical_json(dh.table_to_dict(table, angles=DH_CANONICAL_ANGLES))
        model = dh.model_from_table(table, max_links=self.max_links)
        return self._register(dh_id(canonical), model, canonical, name, SOURCE_DH, json.loads(canonical))

    def _register(self, model_id: str, model: RobotModel, content: bytes, name: str | None, source: str,
                  table: dict[str, Any] | None = None) -> tuple[ModelRecord, bool]:
        """``(record, created)``: the model already stored under ``model_id``, or ``model`` stored now.

        A new record is built from the model the caller parsed, not read and parsed again from disk.
        """
        try:
            return self.get(model_id), False
        except UnknownModelError:
            pass
        meta = {"id": model_id, "name": name or model.name, "source": source, "created": _now()}
        self._store(model_id, meta, content)
        key = _file_key(os.stat(self._content_path(model_id)))
        rec = ModelRecord(model_id, meta["name"], source, model, meta["created"], table, key)
        with self._lock:
            self._stored[model_id] = rec
        return rec, True

    def _store(self, model_id: str, meta: dict[str, Any], content: bytes) -> None:
        """Sidecar, then content, each atomically. A disk that is full or read-only answers a 507
        problem (nothing partial is left: a content file exists whole or not at all)."""
        try:
            atomic_write(self._meta_path(model_id), canonical_json(meta))
            atomic_write(self._content_path(model_id), content)
        except OSError as exc:
            log.error("cannot store model %s in %s: %s", model_id, self.models_dir, exc)
            raise ProblemError(507, f"model {model_id} could not be stored: {exc.strerror or exc}",
                               slug="storage-error", title="Insufficient storage") from None

    def delete(self, model_id: str) -> None:
        """Remove a stored model (content file first, then its sidecar). Bundled ids are refused by the caller."""
        check_model_id(model_id)
        if not (_UPLOAD_ID.match(model_id) or _DH_ID.match(model_id)):
            raise UnknownModelError(f"unknown model {model_id!r}")
        with self._lock:
            self._stored.pop(model_id, None)
        try:
            os.unlink(self._content_path(model_id))
        except FileNotFoundError:
            raise UnknownModelError(f"unknown model {model_id!r}") from None
        try:
            os.unlink(self._meta_path(model_id))
        except FileNotFoundError:
            pass

    # ------------------------------------------------------------------ files
    def _content_path(self, model_id: str) -> Path:
        suffix = URDF_SUFFIX if model_id.startswith(UPLOAD_PREFIX) else DH_SUFFIX
        return self.models_dir / f"{model_id}{suffix}"

    def _meta_path(self, model_id: str) -> Path:
        return self.models_dir / f"{model_id}{META_SUFFIX}"

    def _stored_ids(self) -> list[str]:
        ids = []
        try:
            names = os.listdir(self.models_dir)
        except FileNotFoundError:
            return []
        for fname in sorted(names):
            for suffix, pattern in ((URDF_SUFFIX, _UPLOAD_ID), (DH_SUFFIX, _DH_ID)):
                if fname.endswith(suffix) and pattern.match(fname[: -len(suffix)]):
                    ids.append(fname[: -len(suffix)])
        return ids

    def _load_stored(self, model_id: str) -> ModelRecord:
        """The stored model, from the cache if its file is unchanged, else read from disk.

        Raises FileNotFoundError (gone), ValueError (corrupt or foreign), KinematicsError.
        """
        path = self._content_path(model_id)
        st = os.stat(path)
        key = _file_key(st)
        cached = self._stored.get(model_id)
        if cached is not None and cached.file_key == key:
            return cached
        known_bad = self._unreadable.get(model_id)
        if known_bad is not None and known_bad[0] == key:  # same bad file: refused again, not re-read
            raise _KnownUnreadable(known_bad[1])
        try:
            return self._read_stored(model_id, path, st, key)
        except ValueError as exc:
            with self._lock:
                self._unreadable[model_id] = (key, str(exc))
            raise

    def _read_stored(self, model_id: str, path: Path, st: os.stat_result, key) -> ModelRecord:
        data = path.read_bytes()
        meta = self._read_meta(model_id)
        created = meta.get("created") or datetime.fromtimestamp(st.st_mtime, timezone.utc).isoformat(timespec="seconds")
        table = None
        if model_id.startswith(UPLOAD_PREFIX):
            if urdf_id(data) != model_id:
                raise ValueError(f"{path.name}: content does not hash to its id (corrupt or foreign file)")
            try:
                model = parse_urdf(data, max_links=self.max_links)
            except KinematicsError as exc:
                raise ValueError(f"{path.name}: {exc}") from None
            source = SOURCE_UPLOAD
        else:
            try:
                table = json.loads(data)
                if not isinstance(table, dict):
                    raise ValueError("not a JSON object")
                parsed = dh.table_from_dict(table)
                if dh_id(canonical_json(dh.table_to_dict(parsed, angles=DH_CANONICAL_ANGLES))) != model_id:
                    raise ValueError("content does not hash to its id (corrupt or foreign file)")
                model = dh.model_from_table(parsed, max_links=self.max_links)
            except (ValueError, KinematicsError) as exc:
                raise ValueError(f"{path.name}: {exc}") from None
            source = SOURCE_DH
        name = meta.get("name") if isinstance(meta.get("name"), str) else model.name
        rec = ModelRecord(model_id, name, source, model, created, table, key)
        with self._lock:
            self._stored[model_id] = rec
        return rec

    def _read_meta(self, model_id: str) -> dict[str, Any]:
        try:
            meta = json.loads(self._meta_path(model_id).read_bytes())
            return meta if isinstance(meta, dict) else {}
        except FileNotFoundError:
            return {}
        except (OSError, ValueError) as exc:
            log.warning("ignoring unreadable sidecar of %s: %s", model_id, exc)
            return {}
