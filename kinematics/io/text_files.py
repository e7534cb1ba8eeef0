"""Description files (DH tables, PoE and axes descriptions) read as text within a size bound, and their
mappings' fields."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..errors import KinematicsError

#: the largest description file read (bytes)
MAX_FILE_BYTES = 8 * 1024 * 1024
SUFFIXES = (".yaml", ".yml", ".json")


def read_description_file(path, cls: type[KinematicsError], what: str) -> tuple[str, str]:
    """``(text, suffix)`` of a ``.yaml``/``.yml``/``.json`` file of at most :data:`MAX_FILE_BYTES`;
    errors (of class ``cls``) name the file and ``what`` it should hold."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise cls(f"{path}: a {what} file must end in .yaml, .yml or .json")
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise cls(f"{path}: {size} bytes; a {what} file may have at most {MAX_FILE_BYTES}")
        return path.read_text(encoding="utf-8"), suffix
    except (OSError, UnicodeError) as exc:
        raise cls(f"{path}: cannot read the {what} file: {exc}") from None


def fields(value: Any, keys: set[str], cls: type[KinematicsError], what: str, where: str = "") -> dict:
    """A description's (or one joint's, at ``where``) fields: a mapping, without its null values, of the
    ``keys`` only (``what``: what it is, for the errors)."""
    if not isinstance(value, Mapping):
        raise cls(f"{where}: expected a mapping (JSON object) with {', '.join(sorted(keys))}" if where else
                  f"{what} must be a mapping (JSON object), got {type(value).__name__}")
    value = {k: v for k, v in value.items() if v is not None}
    unknown = set(value) - keys
    if unknown:
        raise cls(f"{where + ': ' if where else ''}unknown field(s) {sorted(unknown)}; {what} has {sorted(keys)}")
    return value
