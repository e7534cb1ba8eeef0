"""Streaming readers and writers of trajectory files: joint values in, poses or Jacobians out.

A trajectory is a sequence of configurations, one per row. Readers yield it in chunks
``(start, Q)`` with ``Q`` a finite float64 array of shape (n, dof) in the model's
``joint_names`` order and ``start`` the index of its first row, so a file of any length is
processed in bounded memory. Writers take the matching result chunks.

Input formats (chosen by extension, or given explicitly):

- ``csv``: comma-separated numbers, one configuration per line. A first line of joint
  names is a header: its columns may come in any order (they are reordered to
  ``joint_names``) and must name every joint once. Without a header the columns are in
  ``joint_names`` order. Blank lines are skipped.
- ``npy``: a numeric (N, dof) array (read memory-mapped, ``allow_pickle=False``).
- ``jsonl``: JSON lines, each a list of ``dof`` numbers in ``joint_names`` order or a
  ``{joint_name: value}`` object. Blank lines are skipped.

Errors raise :class:`TrajectoryFileError` naming the file and the place: ``line L``
(1-based, as an editor shows it) for CSV and JSON lines, ``row R`` (0-based, as numpy
indexes it) for ``.npy``, plus the column (1-based) and its joint.

Output formats:

- FK, ``csv``: per link, columns ``<link>.x, <link>.y, <link>.z`` (position of the link
  frame in the world frame, metres) and ``<link>.qw, <link>.qx, <link>.qy, <link>.qz``
  (its orientation ``R_world_link`` as a unit quaternion, ``qw >= 0``).
- FK, ``npy``: ``T_world_link`` of shape (N, L, 4, 4).
- FK, ``jsonl``: per row ``{"poses": {link: {"matrix", "position", "quaternion", "rpy"}}}``,
  the pose objects of the REST API.
- Jacobian, ``csv``: ``6 * dof`` columns ``J<r><c>``, row-major: ``r`` in 0..5 is the row
  (0-2 linear x, y, z; 3-5 angular x, y, z), ``c`` the 0-based column (joint index in
  ``joint_names``), e.g. ``J00, J01, ..., J0<dof-1>, J10, ...``.
- Jacobian, ``npy``: (N, 6, dof); ``jsonl``: per row ``{"jacobian": [[...] x 6]}``.

Floats are written so they read back exactly (shortest round-trip repr in text formats).
The ``.npy`` writer streams: it reserves a fixed-size header, appends each chunk, and
writes the final row count into the header when it is closed, so the row count need not
be known in advance (``numpy.lib.format.open_memmap`` needs it up front).
"""

from __future__ import annotations

import csv
import io
import itertools
import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path


import numpy as np

from ..errors import KinematicsError
from ..model.robot import RobotModel
from ..spatial.rotations import matrix_to_quaternion
from ..tolerances import MAX_ABS_JOINT_VALUE
from .pose_records import pose_output

#: configurations processed per chunk (bounds the memory of a streaming run)
CHUNK_ROWS = 10_000

FORMATS = ("csv", "npy", "jsonl")

#: file extensions of each format (lower case)
EXTENSIONS = {
    ".csv": "csv",
    ".txt": "csv",
    ".npy": "npy",
    ".jsonl": "jsonl",
    ".ndjson": "jsonl",
}

#: bytes reserved for the header of a streamed .npy file (magic and length included);
#: a multiple of 64 as numpy aligns it, and room for any shape.
NPY_HEADER_BYTES = 256

#: what is shown of a bad value in an error message
_SHOW = 40


class TrajectoryFileError(KinematicsError):
    """A trajectory file that cannot be read or written (message names file, line/row, column)."""


def format_of(path: str | os.PathLike, explicit: str | None = None) -> str:
    """The format (``csv``, ``npy``, ``jsonl``) of ``path`` from its extension, or ``explicit``."""
    if explicit is not None:
        if explicit not in FORMATS:
            raise TrajectoryFileError(f"unknown format {explicit!r}; expected one of {', '.join(FORMATS)}")
        return explicit
    ext = Path(str(path)).suffix.lower()
    try:
        return EXTENSIONS[ext]
    except KeyError:
        raise TrajectoryFileError(
            f"{path}: cannot tell the format from the extension {ext or '(none)'!r}: "
            f"use one of {', '.join(sorted(EXTENSIONS))} or give the format explicitly"
        ) from None


def _short(text: str) -> str:
    text = text.strip()
    return repr(text if len(text) <= _SHOW else text[:_SHOW] + "...")


# ============================================================================ readers
class JointRows:
    """Configurations of a trajectory file, read in chunks.

    Iterating yields ``(start, Q)``: ``Q`` (n, dof) float64, finite, columns in
    ``model.joint_names`` order; ``start`` the 0-based index of its first configuration.
    ``total`` is the number of configurations when known in advance (``.npy``), else None.
    Use as a context manager (or call :meth:`close`) to release the file.
    """

    def __init__(self, source, model: RobotModel, fmt: str, name: str, chunk_rows: int = CHUNK_ROWS):
        if model.dof == 0:
            raise TrajectoryFileError(f"model {model.name!r} has no moving joint: there is no joint value to read")
        if chunk_rows < 1:
            raise ValueError("chunk_rows must be positive")
        self.model = model
        self.format = fmt
        self.name = name
        self.chunk_rows = chunk_rows
        self.total: int | None = None
        self._close = None
        self._array = None
        self._fh = None
        if fmt == "npy":
            self._array = _load_npy(source, model, name)
            self.total = int(self._array.shape[0])
        else:
            if isinstance(source, (str, os.PathLike)):
                try:
                    self._fh = open(source, encoding="utf-8", newline=None)
                except OSError as exc:
                    raise TrajectoryFileError(f"{name}: cannot open: {exc.strerror or exc}") from None
                self._close = self._fh.close
            else:
                self._fh = source

    def __enter__(self) -> "JointRows":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        if self._close is not None:
            self._close()
            self._close = None
        self._array = None

    def __iter__(self) -> Iterator[tuple[int, np.ndarray]]:
        try:
            if self.format == "npy":
                yield from self._npy_chunks()
            elif self.format == "csv":
                yield from self._csv_chunks()
            else:
                yield from self._jsonl_chunks()
        except UnicodeDecodeError as exc:
            raise TrajectoryFileError(f"{self.name}: not UTF-8 text ({exc.reason} at byte {exc.start} of a block)") from None

    # ------------------------------------------------------------------ common
    def _where_joint(self, col: int) -> str:
        """``column C (joint 'name')`` for a 0-based column of Q."""
        return f"joint {self.model.joint_names[col]!r}"

    def _check_finite(self, Q: np.ndarray, place) -> None:
        """Raise naming the first non-finite value; ``place(k, j)`` names row k, column j of Q."""
        bad = ~np.isfinite(Q)
        if bad.any():
            k, j = map(int, np.argwhere(bad)[0])
            raise TrajectoryFileError(f"{self.name}: {place(k, j)}: value {Q[k, j]} is not finite")
        huge = np.abs(Q) > MAX_ABS_JOINT_VALUE  # as kinematics.as_batch: no FK overflow to inf
        if huge.any():
            k, j = map(int, np.argwhere(huge)[0])
            raise TrajectoryFileError(
                f"{self.name}: {place(k, j)}: value {Q[k, j]:g} is beyond +-{MAX_ABS_JOINT_VALUE:g}"
            )

    # ------------------------------------------------------------------ npy
    def _npy_chunks(self):
        arr = self._array
        for start in range(0, arr.shape[0], self.chunk_rows):
            Q = np.array(arr[start : start + self.chunk_rows], dtype=np.float64)
            if Q.ndim == 1:
                Q = Q[:, None]
            self._check_finite(Q, lambda k, j: f"row {start + k}, column {j + 1} ({self._where_joint(j)})")
            yield start, Q

    # ------------------------------------------------------------------ CSV
    def _csv_chunks(self):
        fh, model = self._fh, self.model
        line_no = 0
        first = None
        for line in fh:
            line_no += 1
            if line.strip():
                first = line
                break
        if first is None:
            return  # an empty file has no configuration
        fields = [f.strip() for f in next(csv.reader([first]))]
        if _looks_like_header(fields):
            self.columns = fields
            perm = _header_permutation(fields, model, self.name, line_no)
            pending: list[str] = []
            next_line = line_no + 1
        else:
            self.columns = list(model.joint_names)
            perm = None
            pending = [first]
            next_line = line_no
        ncols = len(self.columns)
        start = 0
        while True:
            raw = pending + list(itertools.islice(fh, self.chunk_rows - len(pending)))
            pending = []
            if not raw:
                return
            first_line = next_line
            next_line += len(raw)
            data = [l for l in raw if l.strip()]
            if not data:
                continue
            arr = self._parse_csv_block(raw, data, first_line, ncols)
            Q = arr if perm is None else arr[:, perm]
            Q = np.ascontiguousarray(Q, dtype=np.float64)

            def place(k, j, raw=raw, first_line=first_line):
                file_col = j if perm is None else int(perm[j])
                return f"line {_nth_data_line(raw, first_line, k)}, column {file_col + 1} ({self._where_joint(j)})"

            self._check_finite(Q, place)
            yield start, Q
            start += Q.shape[0]

    def _parse_csv_block(self, raw: list[str], data: list[str], first_line: int, ncols: int) -> np.ndarray:
        """(n, ncols) floats of the non-blank lines ``data`` of ``raw`` (which starts at ``first_line``)."""
        try:
            arr = np.loadtxt(data, delimiter=",", dtype=np.float64, ndmin=2, comments=None, encoding=None)
            if arr.shape[1] == ncols:
                return arr
        except ValueError:
            pass
        # slow path: find (and name) the problem, or parse what loadtxt refused (e.g. quoted numbers)
        rows = []
        for i, line in enumerate(raw):
            if not line.strip():
                continue
            fields = next(csv.reader([line]))
            where = f"line {first_line + i}"
            if len(fields) != ncols:
                raise TrajectoryFileError(
                    f"{self.name}: {where}: expected {ncols} columns "
                    f"({', '.join(self.columns) if len(self.columns) <= 12 else 'one per joint'}), got {len(fields)}"
                )
            row = []
            for c, text in enumerate(fields):
                try:
                    row.append(float(text.strip()))
                except ValueError:
                    raise TrajectoryFileError(
                        f"{self.name}: {where}, column {c + 1} ({self._column_label(c)}): {_short(text)} is not a number"
                    ) from None
            rows.append(row)
        return np.array(rows, dtype=np.float64).reshape(len(rows), ncols)

    def _column_label(self, c: int) -> str:
        return f"joint {self.columns[c]!r}"

    # ------------------------------------------------------------------ JSON lines
    def _jsonl_chunks(self):
        fh, model, dof = self._fh, self.model, self.model.dof
        names = model.joint_names
        name_set = set(names)
        line_no = 0
        start = 0
        while True:
            raw = list(itertools.islice(fh, self.chunk_rows))
            if not raw:
                return
            rows, lines = [], []
            for line in raw:
                line_no += 1
                if not line.strip():
                    continue
                where = f"{self.name}: line {line_no}"
                try:
                    obj = json.loads(line)
                except json.JSONDecodeError as exc:
                    raise TrajectoryFileError(f"{where}: not valid JSON ({exc.msg} at character {exc.colno})") from None
                if isinstance(obj, list):
                    if len(obj) != dof:
                        raise TrajectoryFileError(
                            f"{where}: expected {dof} joint values (in the order {list(names)}), got {len(obj)}"
                        )
                    values = obj
                elif isinstance(obj, dict):
                    if obj.keys() != name_set:
                        unknown = [k for k in obj if k not in name_set]
                        if unknown:
                            raise TrajectoryFileError(f"{where}: unknown joint name(s): {', '.join(map(str, unknown))}")
                        missing = [n for n in names if n not in obj]
                        raise TrajectoryFileError(f"{where}: missing value(s) for joint(s): {', '.join(missing)}")
                    values = [obj[n] for n in names]
                else:
                    raise TrajectoryFileError(
                        f"{where}: expected a list of {dof} numbers or a {{joint: value}} object, got {type(obj).__name__}"
                    )
                for c, v in enumerate(values):
                    if type(v) is not float and type(v) is not int:
                        raise TrajectoryFileError(
                            f"{where}, column {c + 1} (joint {names[c]!r}): {json.dumps(v)[:_SHOW]} is not a number"
                        )
                rows.append(values)
                lines.append(line_no)
            if not rows:
                continue
            Q = np.array(rows, dtype=np.float64).reshape(len(rows), dof)
            self._check_finite(Q, lambda k, j: f"line {lines[k]}, column {j + 1} ({self._where_joint(j)})")
            yield start, Q
            start += Q.shape[0]


def _looks_like_header(fields: list[str]) -> bool:
    """A first CSV line is a header when any of its fields is not a number."""
    for f in fields:
        try:
            float(f)
        except ValueError:
            return True
    return False


def _header_permutation(fields: list[str], model: RobotModel, name: str, line_no: int) -> np.ndarray:
    """Column of the file holding each joint of ``model.joint_names``, from a header line."""
    where = f"{name}: line {line_no} (header)"
    seen: dict[str, int] = {}
    for c, f in enumerate(fields):
        if f not in model.q_index:
            hint = ""
            joint = model.joint_map.get(f)
            if joint is not None and joint.mimic is not None:
                hint = " (a mimic joint: its value follows its leader)"
            elif joint is not None:
                hint = " (a fixed joint)"
            raise TrajectoryFileError(
                f"{where}, column {c + 1}: unknown joint {f!r}{hint}; the model's joints are {', '.join(model.joint_names)}"
            )
        if f in seen:
            raise TrajectoryFileError(f"{where}, column {c + 1}: joint {f!r} repeats column {seen[f] + 1}")
        seen[f] = c
    missing = [n for n in model.joint_names if n not in seen]
    if missing:
        raise TrajectoryFileError(f"{where}: no column for joint(s) {', '.join(missing)}")
    return np.array([seen[n] for n in model.joint_names], dtype=np.intp)


def _nth_data_line(raw: list[str], first_line: int, k: int) -> int:
    """Line number of the k-th (0-based) non-blank line of ``raw``, which starts at ``first_line``."""
    n = -1
    for i, line in enumerate(raw):
        if line.strip():
            n += 1
            if n == k:
                return first_line + i
    raise IndexError(k)  # pragma: no cover - k always indexes a parsed line


def _load_npy(source, model: RobotModel, name: str) -> np.ndarray:
    try:
        arr = np.load(source, mmap_mode="r", allow_pickle=False)
    except ValueError as exc:  # object arrays, bad header
        raise TrajectoryFileError(f"{name}: cannot read as .npy: {exc}") from None
    except (OSError, EOFError) as exc:
        raise TrajectoryFileError(f"{name}: cannot read as .npy: {getattr(exc, 'strerror', None) or exc}") from None
    if not isinstance(arr, np.ndarray):
        raise TrajectoryFileError(f"{name}: not a single .npy array (an .npz archive?)")
    if arr.dtype.kind not in "fiu":
        raise TrajectoryFileError(f"{name}: joint values must be numbers, the array has dtype {arr.dtype}")
    dof = model.dof
    if arr.ndim == 1 and dof == 1:
        return arr
    if arr.ndim != 2 or arr.shape[1] != dof:
        raise TrajectoryFileError(
            f"{name}: expected an array of shape (N, {dof}) (one column per joint: {', '.join(model.joint_names)}), "
            f"got shape {arr.shape}"
        )
    return arr


def open_joint_rows(path, model: RobotModel, fmt: str | None = None, chunk_rows: int = CHUNK_ROWS) -> JointRows:
    """Open a trajectory file (a path, or a text stream for ``csv``/``jsonl``) for chunked reading."""
    if isinstance(path, (str, os.PathLike)):
        fmt = format_of(path, fmt)
        return JointRows(path, model, fmt, str(path), chunk_rows)
    fmt = fmt or "csv"
    if fmt == "npy":
        raise TrajectoryFileError(".npy input must be a file, not a stream")
    return JointRows(path, model, fmt, getattr(path, "name", "<stream>"), chunk_rows)


# ============================================================================ writers
def fk_columns(links) -> list[str]:
    """CSV column names of FK output: per link ``x, y, z, qw, qx, qy, qz``."""
    return [f"{l}.{c}" for l in links for c in ("x", "y", "z", "qw", "qx", "qy", "qz")]


def jacobian_columns(dof: int) -> list[str]:
    """CSV column names of Jacobian output: ``J<r><c>`` row-major, r in 0..5, c in 0..dof-1."""
    return [f"J{r}{c}" for r in range(6) for c in range(dof)]


def fk_table(T: np.ndarray) -> np.ndarray:
    """(n, L, 4, 4) poses -> (n, 7 L) rows of ``x, y, z, qw, qx, qy, qz`` per link."""
    n, L = T.shape[:2]
    out = np.empty((n, L, 7))
    out[..., :3] = T[..., :3, 3]
    out[..., 3:] = matrix_to_quaternion(T[..., :3, :3])
    return out.reshape(n, 7 * L)


class ResultWriter:
    """Writes result chunks to a file (atomically: a temporary file renamed on success) or a stream.

    ``kind`` is ``fk`` (chunks (n, L, 4, 4), ``labels`` the link names) or ``jacobian``
    (chunks (n, 6, dof), ``labels`` the joint names). Use as a context manager: on an
    exception the partial file is removed and the destination left untouched.
    """

    def __init__(self, dest, fmt: str, kind: str, labels, name: str | None = None):
        if kind not in ("fk", "jacobian"):
            raise ValueError(kind)
        self.fmt, self.kind, self.labels = fmt, kind, list(labels)
        self.rows = 0
        self._tmp: str | None = None
        self._dest: str | None = None
        if isinstance(dest, (str, os.PathLike)):
            self._dest = str(dest)
            self.name = name or self._dest
            folder = os.path.dirname(os.path.abspath(self._dest))
            try:
                fd, self._tmp = tempfile.mkstemp(prefix=f".{os.path.basename(self._dest)}.", suffix=".part", dir=folder)
            except OSError as exc:
                raise TrajectoryFileError(f"{self.name}: cannot write: {exc.strerror or exc}") from None
            os.chmod(self._tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the usual permissions
            self._fh = os.fdopen(fd, "wb" if fmt == "npy" else "w", **({} if fmt == "npy" else {"encoding": "utf-8", "newline": "\n"}))
        else:
            if fmt == "npy":
                raise TrajectoryFileError(".npy output must go to a file (it is finished by rewriting its header)")
            self._fh = dest
            self.name = name or getattr(dest, "name", "<stream>")
        self._tail: tuple[int, ...] | None = None
        self._started = False  # the CSV header / npy placeholder go out with the first chunk (or on close)

    def _start(self) -> None:
        self._started = True
        if self.fmt == "npy":
            self._fh.write(b"\0" * NPY_HEADER_BYTES)  # the real header is written on close
        elif self.fmt == "csv":
            cols = fk_columns(self.labels) if self.kind == "fk" else jacobian_columns(len(self.labels))
            self._fh.write(",".join(cols) + "\n")

    def __enter__(self) -> "ResultWriter":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()

    def write(self, chunk: np.ndarray) -> None:
        """Append a chunk of results: (n, L, 4, 4) for FK, (n, 6, dof) for Jacobians."""
        chunk = np.asarray(chunk, dtype=np.float64)
        n = chunk.shape[0]
        if not self._started:
            self._start()
        if self.fmt == "npy":
            if self._tail is None:
                self._tail = tuple(chunk.shape[1:])
            elif tuple(chunk.shape[1:]) != self._tail:
                raise ValueError(f"chunk shape {chunk.shape[1:]} differs from {self._tail}")
            self._fh.write(np.ascontiguousarray(chunk).tobytes())
        elif self.fmt == "csv":
            table = fk_table(chunk) if self.kind == "fk" else chunk.reshape(n, -1)
            buf = io.StringIO()
            buf.writelines(",".join(map(repr, row)) + "\n" for row in table.tolist())
            self._fh.write(buf.getvalue())
        else:
            self._fh.write("".join(json.dumps(rec, allow_nan=True, default=np.ndarray.tolist) + "\n" for rec in self._json_records(chunk)))
        self.rows += n

    def _json_records(self, chunk: np.ndarray):
        if self.kind == "jacobian":
            for J in chunk:
                yield {"jacobian": J.tolist()}
            return
        for poses in pose_output(chunk, self.labels):
            yield {"poses": poses}

    def close(self) -> None:
        """Finish the output (the .npy header; the rename into place)."""
        if self._fh is None:
            return
        if not self._started:
            self._start()
        try:
            if self.fmt == "npy":
                tail = self._tail
                if tail is None:  # no rows: the shape still tells what a row would hold
                    tail = (len(self.labels), 4, 4) if self.kind == "fk" else (6, len(self.labels))
                self._fh.seek(0)
                self._fh.write(npy_header((self.rows,) + tail))
            self._fh.flush()
        finally:
            if self._tmp is not None:
                self._fh.close()
        self._fh = None
        if self._tmp is not None:
            os.replace(self._tmp, self._dest)
            self._tmp = None

    def abort(self) -> None:
        """Drop a partial output file (the destination is left as it was)."""
        if self._tmp is not None:
            try:
                self._fh.close()
            finally:
                try:
                    os.unlink(self._tmp)
                except FileNotFoundError:
                    pass
                self._tmp = None
        self._fh = None


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def npy_header(shape: tuple[int, ...]) -> bytes:
    """A version 1.0 ``.npy`` header for C-ordered little-endian float64 of ``shape``,
    padded to exactly :data:`NPY_HEADER_BYTES` bytes."""
    from numpy.lib import format as npy_format

    d = {"descr": "<f8", "fortran_order": False, "shape": tuple(int(s) for s in shape)}
    text = repr(d)
    magic = npy_format.magic(1, 0)
    body_len = NPY_HEADER_BYTES - len(magic) - 2
    if len(text) + 1 > body_len:  # pragma: no cover - 256 bytes fit any realistic shape
        raise ValueError(f"shape {shape} does not fit in a {NPY_HEADER_BYTES}-byte header")
    body = text.ljust(body_len - 1) + "\n"
    return magic + body_len.to_bytes(2, "little") + body.encode("latin1")


# ============================================================================ sampling
class RowSampler:
    """A uniform random sample of ``k`` rows of a stream, kept with their results.

    Each offered row gets a random key; the ``k`` rows with the smallest keys are kept
    (a reservoir sample, vectorised per chunk).
    """

    def __init__(self, k: int, seed: int = 0):
        self.k = int(k)
        self.rng = np.random.default_rng(seed)
        self.keys = np.empty(0)
        self.rows = np.empty(0, dtype=np.int64)
        self.Q: np.ndarray | None = None
        self.results: np.ndarray | None = None

    def offer(self, start: int, Q: np.ndarray, results: np.ndarray) -> None:
        if self.k <= 0 or Q.shape[0] == 0:
            return
        keys = self.rng.random(Q.shape[0])
        rows = np.arange(start, start + Q.shape[0])
        if self.Q is None:
            all_keys, all_rows, all_Q, all_R = keys, rows, Q, results
        else:
            all_keys = np.concatenate([self.keys, keys])
            all_rows = np.concatenate([self.rows, rows])
            all_Q = np.concatenate([self.Q, Q])
            all_R = np.concatenate([self.results, results])
        keep = np.argsort(all_keys, kind="stable")[: self.k]
        keep.sort()
        self.keys, self.rows = all_keys[keep], all_rows[keep]
        self.Q, self.results = all_Q[keep].copy(), all_R[keep].copy()
