"""Streaming readers and writers of trajectory files: joint values (or IK targets) in, poses,
Jacobians (or IK answers) out.

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

Target poses (the input of inverse kinematics, ``T_world_link``) are read the same way by
:class:`TargetRows`, in chunks ``(start, T)`` with ``T`` (n, 4, 4):

- ``csv``: ``x, y, z, qw, qx, qy, qz`` per line (position in metres, orientation as a unit
  quaternion, w first), or the 16 entries of the 4x4 matrix, row-major. A header names the
  columns in any order (``x ... qz``, or ``T00 ... T33``; a common prefix such as ``tool0.``,
  as FK output of one link has, is dropped).
- ``npy``: (N, 4, 4) matrices or (N, 7) rows ``x, y, z, qw, qx, qy, qz``.
- ``jsonl``: per line a list of 7 numbers ``x, y, z, qw, qx, qy, qz``, or a pose in any form
  :func:`~kinematics.io.poses.pose_list` reads (a 4x4 matrix, ``{"position", "quaternion"}``,
  ``{"xyz", "rpy"}``).

A quaternion must be unit to :data:`~kinematics.tolerances.RIGID_TOLERANCE` (it is then
normalised), a matrix a rigid transform to the same tolerance.

Errors raise :class:`TrajectoryFileError` naming the file and the place: ``line L``
(1-based, as an editor shows it) for CSV and JSON lines, ``row R`` (0-based, as numpy
indexes it) for ``.npy``, plus the column (1-based) and its joint (or pose component).

The result files written from these chunks: :mod:`kinematics.io.result_files`.
"""

from __future__ import annotations

import csv
import itertools
import json
import os
from collections.abc import Iterator
from pathlib import Path


import numpy as np

from ..errors import KinematicsError, PoseError
from ..model.robot import RobotModel
from ..spatial.rotations import matrix_to_quaternion, quaternion_to_matrix
from ..spatial.transforms import is_rigid_transform
from ..tolerances import MAX_ABS_COORDINATE, MAX_ABS_JOINT_VALUE, RIGID_TOLERANCE
from .poses import pose_list

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
class _RowFile:
    """Rows of numbers of a CSV, ``.npy`` or JSON-lines file, read in chunks: the machinery
    :class:`JointRows` and :class:`TargetRows` share (opening, chunking, CSV headers and
    blocks, JSON lines, ``.npy`` loading, and messages naming the line or row and column).

    A subclass sets ``names`` (the columns, in the order a chunk has them) and says how a
    header, a ``.npy`` array and a JSON line map onto them (:meth:`_header`, :meth:`_npy_rows`,
    :meth:`_json_row`), how a block is checked (:meth:`_check`) and what a chunk yields
    (:meth:`_chunk`). Iterating yields ``(start, chunk)``, ``start`` the 0-based index of the
    chunk's first row; ``total`` is the number of rows when known in advance (``.npy``), else
    None. Use as a context manager (or call :meth:`close`) to release the file.
    """

    #: what the rows hold, for messages (``joint values``)
    what = "values"
    #: how a message describes the columns when there are too many to list
    many_columns = "one per column"
    #: largest magnitude of a value
    max_abs = MAX_ABS_COORDINATE

    def __init__(self, source, fmt: str, name: str, chunk_rows: int = CHUNK_ROWS):
        if chunk_rows < 1:
            raise ValueError("chunk_rows must be positive")
        self.format = fmt
        self.name = name
        self.chunk_rows = chunk_rows
        self.columns = list(self.names)  # the file's columns (a CSV header may reorder them)
        self.total: int | None = None
        self._close = None
        self._array = None
        self._fh = None
        if fmt == "npy":
            self._array = self._npy_rows(_open_npy(source, name, self.what))
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

    def __enter__(self):
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

    # ------------------------------------------------------------------ what a subclass says
    def _label(self, column: str) -> str:
        """How a message names a column (``joint 'elbow'``)."""
        return column

    def _header(self, fields: list[str], line_no: int) -> np.ndarray:
        """Column of the file holding each of ``names``, from a CSV header (may set ``names``)."""
        raise NotImplementedError

    def _no_header(self, fields: list[str], line_no: int) -> None:
        """A CSV without a header, whose first row is ``fields`` (may set ``names``)."""

    def _npy_rows(self, arr: np.ndarray) -> np.ndarray:
        """The (N, len(names)) rows of a ``.npy`` array (may set ``names``), or raise."""
        raise NotImplementedError

    def _json_row(self, obj, where: str, line_no: int) -> list:
        """The numbers (one per name) of a parsed JSON line, or raise naming ``where``."""
        raise NotImplementedError

    def _chunk(self, A: np.ndarray):
        """What a chunk yields for a checked block ``A`` (n, len(names))."""
        return A

    def _check(self, A: np.ndarray, row_of, col_of) -> None:
        """Raise naming the first non-finite value of ``A`` (n, len(names)), or one beyond
        ``max_abs``; ``row_of(k)`` names row k of ``A`` (``line 3``), ``col_of(j)`` is the
        0-based file column of its column j."""
        bad = ~np.isfinite(A)
        if bad.any():
            k, j = map(int, np.argwhere(bad)[0])
            raise TrajectoryFileError(f"{self.name}: {self._place(row_of, col_of, k, j)}: value {A[k, j]} is not finite")
        huge = np.abs(A) > self.max_abs  # as kinematics.as_batch: no FK overflow to inf
        if huge.any():
            k, j = map(int, np.argwhere(huge)[0])
            raise TrajectoryFileError(
                f"{self.name}: {self._place(row_of, col_of, k, j)}: value {A[k, j]:g} is beyond +-{self.max_abs:g}"
            )

    def _place(self, row_of, col_of, k: int, j: int) -> str:
        """``line L, column C (label)`` of row k, column j of a block."""
        return f"{row_of(k)}, column {col_of(j) + 1} ({self._label(self.names[j])})"

    def _numbers(self, values: list, where: str) -> list:
        """``values`` of a JSON line, each a number (else raise naming its column)."""
        for c, v in enumerate(values):
            if type(v) is not float and type(v) is not int:
                raise TrajectoryFileError(
                    f"{where}, column {c + 1} ({self._label(self.names[c])}): {json.dumps(v)[:_SHOW]} is not a number"
                )
        return values

    # ------------------------------------------------------------------ npy
    def _npy_chunks(self):
        arr = self._array
        for start in range(0, arr.shape[0], self.chunk_rows):
            A = np.array(arr[start : start + self.chunk_rows], dtype=np.float64)
            if A.ndim == 1:
                A = A[:, None]
            self._check(A, lambda k: f"row {start + k}", lambda j: j)
            yield start, self._chunk(A)

    # ------------------------------------------------------------------ CSV
    def _csv_chunks(self):
        fh = self._fh
        line_no = 0
        first = None
        for line in fh:
            line_no += 1
            if line.strip():
                first = line
                break
        if first is None:
            return  # an empty file has no row
        fields = [f.strip() for f in next(csv.reader([first]))]
        if _looks_like_header(fields):
            perm = self._header(fields, line_no)
            pending: list[str] = []
            next_line = line_no + 1
        else:
            self._no_header(fields, line_no)
            self.columns = list(self.names)
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
            A = arr if perm is None else arr[:, perm]
            A = np.ascontiguousarray(A, dtype=np.float64)

            def row_of(k, raw=raw, first_line=first_line):
                return f"line {_nth_data_line(raw, first_line, k)}"

            self._check(A, row_of, lambda j: j if perm is None else int(perm[j]))
            yield start, self._chunk(A)
            start += A.shape[0]

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
                    f"({', '.join(self.columns) if len(self.columns) <= 12 else self.many_columns}), got {len(fields)}"
                )
            row = []
            for c, text in enumerate(fields):
                try:
                    row.append(float(text.strip()))
                except ValueError:
                    raise TrajectoryFileError(
                        f"{self.name}: {where}, column {c + 1} ({self._label(self.columns[c])}): {_short(text)} is not a number"
                    ) from None
            rows.append(row)
        return np.array(rows, dtype=np.float64).reshape(len(rows), ncols)

    # ------------------------------------------------------------------ JSON lines
    def _jsonl_chunks(self):
        fh = self._fh
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
                rows.append(self._json_row(obj, where, line_no))
                lines.append(line_no)
            if not rows:
                continue
            A = np.array(rows, dtype=np.float64).reshape(len(rows), len(self.names))
            self._check(A, lambda k: f"line {lines[k]}", lambda j: j)
            yield start, self._chunk(A)
            start += A.shape[0]


#: suffix of a joint's velocity column in a CSV header of joint states (``elbow_joint.qdot``)
QDOT_SUFFIX = ".qdot"


class _ModelRows(_RowFile):
    """Rows of a model's joints: one column per joint for each of :attr:`suffixes` (``""``: the joint
    values, :data:`QDOT_SUFFIX`: their velocities), ``joints`` in ``model.joint_names`` order."""

    max_abs = MAX_ABS_JOINT_VALUE
    #: the column groups, each one column per joint named ``<joint><suffix>``
    suffixes = ("",)

    def __init__(self, source, model: RobotModel, fmt: str, name: str, chunk_rows: int = CHUNK_ROWS):
        require_joint_columns(model)
        self.model = model
        self.dof = model.dof
        self.joints = list(model.joint_names)
        self._name_set = set(self.joints)
        self.names = [n + suffix for suffix in self.suffixes for n in self.joints]
        super().__init__(source, fmt, name, chunk_rows)


class JointRows(_ModelRows):
    """Configurations of a trajectory file, read in chunks.

    Iterating yields ``(start, Q)``: ``Q`` (n, dof) float64, finite, columns in
    ``model.joint_names`` order; ``start`` the 0-based index of its first configuration.
    ``total`` is the number of configurations when known in advance (``.npy``), else None.
    Use as a context manager (or call :meth:`close`) to release the file.
    """

    what = "joint values"
    many_columns = "one per joint"

    def _label(self, column: str) -> str:
        return f"joint {column!r}"

    def _header(self, fields, line_no):
        self.columns = fields
        model = self.model

        def hint(f: str) -> str:
            joint = model.joint_map.get(f)
            if joint is not None and joint.mimic is not None:
                return " (a mimic joint: its value follows its leader)"
            return " (a fixed joint)" if joint is not None else ""

        return _column_permutation(fields, self.names, f"{self.name}: line {line_no} (header)", "joint",
                                   f"the model's joints are {', '.join(self.names)}", hint)

    def _npy_rows(self, arr):
        dof = self.model.dof
        if arr.ndim == 1 and dof == 1:
            return arr
        if arr.ndim != 2 or arr.shape[1] != dof:
            raise TrajectoryFileError(
                f"{self.name}: expected an array of shape (N, {dof}) (one column per joint: {', '.join(self.names)}), "
                f"got shape {arr.shape}"
            )
        return arr

    def _json_row(self, obj, where, line_no):
        names, dof = self.names, len(self.names)
        if isinstance(obj, list):
            if len(obj) != dof:
                raise TrajectoryFileError(f"{where}: expected {dof} joint values (in the order {names}), got {len(obj)}")
            return self._numbers(obj, where)
        if isinstance(obj, dict):
            if obj.keys() != self._name_set:
                unknown = [k for k in obj if k not in self._name_set]
                if unknown:
                    raise TrajectoryFileError(f"{where}: unknown joint name(s): {', '.join(map(str, unknown))}")
                missing = [n for n in names if n not in obj]
                raise TrajectoryFileError(f"{where}: missing value(s) for joint(s): {', '.join(missing)}")
            return self._numbers([obj[n] for n in names], where)
        raise TrajectoryFileError(
            f"{where}: expected a list of {dof} numbers or a {{joint: value}} object, got {type(obj).__name__}"
        )


class StateRows(_ModelRows):
    """Joint values and joint velocities of a trajectory file, read in chunks (the input of
    ``kinematics velocity``).

    Iterating yields ``(start, (Q, Qd))``, both (n, dof) float64 in ``model.joint_names`` order.
    A row holds ``2 dof`` numbers: the joint values, then the joint velocities. A CSV header
    names the columns in any order: the joint names for q and ``<joint>.qdot`` for qdot. A JSON
    line is a list of ``2 dof`` numbers or ``{"q": ..., "qdot": ...}`` (each a list in
    ``joint_names`` order or a ``{joint: value}`` object); ``.npy`` is (N, 2 dof).
    """

    what = "joint values and velocities"
    many_columns = "one per joint, then one velocity per joint"
    suffixes = ("", QDOT_SUFFIX)

    def _label(self, column: str) -> str:
        if column.endswith(QDOT_SUFFIX) and column[: -len(QDOT_SUFFIX)] in self.model.joint_map:
            return f"velocity of joint {column[: -len(QDOT_SUFFIX)]!r}"
        return f"joint {column!r}"

    def _header(self, fields, line_no):
        self.columns = fields
        return _column_permutation(fields, self.names, f"{self.name}: line {line_no} (header)", "column",
                                   f"the columns are the joint names ({', '.join(self.joints)}) and the same "
                                   f"with {QDOT_SUFFIX!r} appended (the velocities)")

    def _npy_rows(self, arr):
        if arr.ndim != 2 or arr.shape[1] != 2 * self.dof:
            raise TrajectoryFileError(
                f"{self.name}: expected an array of shape (N, {2 * self.dof}) (the {self.dof} joint values, then "
                f"the {self.dof} joint velocities), got shape {arr.shape}")
        return arr

    def _one(self, value, where: str, what: str) -> list:
        names, dof = self.joints, self.dof
        if isinstance(value, list):
            if len(value) != dof:
                raise TrajectoryFileError(f"{where}: {what}: expected {dof} numbers (in the order {names}), got {len(value)}")
            return value
        if isinstance(value, dict):
            unknown = [k for k in value if k not in self.model.joint_map or k not in names]
            if unknown:
                raise TrajectoryFileError(f"{where}: {what}: unknown joint name(s): {', '.join(map(str, unknown))}")
            missing = [n for n in names if n not in value]
            if missing:
                raise TrajectoryFileError(f"{where}: {what}: missing value(s) for joint(s): {', '.join(missing)}")
            return [value[n] for n in names]
        raise TrajectoryFileError(f"{where}: {what}: expected a list of {dof} numbers or a {{joint: value}} object")

    def _json_row(self, obj, where, line_no):
        if isinstance(obj, list):
            if len(obj) != 2 * self.dof:
                raise TrajectoryFileError(f"{where}: expected {2 * self.dof} numbers (joint values, then joint "
                                          f"velocities), got {len(obj)}")
            return self._numbers(obj, where)
        if isinstance(obj, dict) and set(obj) == {"q", "qdot"}:
            return self._numbers(self._one(obj["q"], where, "q") + self._one(obj["qdot"], where, "qdot"), where)
        raise TrajectoryFileError(f"{where}: expected a list of {2 * self.dof} numbers or {{\"q\": ..., \"qdot\": ...}}")

    def _chunk(self, A):
        return np.ascontiguousarray(A[:, : self.dof]), np.ascontiguousarray(A[:, self.dof:])


#: columns of a target pose: position (metres) and orientation quaternion (w first)
POSE_COLUMNS = ("x", "y", "z", "qw", "qx", "qy", "qz")
#: columns of a target given as its 4x4 matrix, row-major: ``T<r><c>``
MATRIX_COLUMNS = tuple(f"T{r}{c}" for r in range(4) for c in range(4))
_TARGET_COLUMNS = f"{', '.join(POSE_COLUMNS)} (or T00 ... T33: a 4x4 matrix, row-major)"


class TargetRows(_RowFile):
    """Target poses ``T_world_link`` of a file, read in chunks (the input of inverse kinematics).

    Iterating yields ``(start, T)``: ``T`` (n, 4, 4) float64 rigid transforms; ``start`` the
    0-based index of its first target. A row is ``x, y, z, qw, qx, qy, qz`` (the quaternion unit
    to :data:`~kinematics.tolerances.RIGID_TOLERANCE`, then normalised) or, in CSV and ``.npy``,
    the 16 entries of the matrix, row-major (a rigid transform). ``total`` as :class:`JointRows`.
    """

    what = "targets"
    many_columns = "a 4x4 matrix, row-major"
    max_abs = MAX_ABS_COORDINATE

    def __init__(self, source, fmt: str, name: str, chunk_rows: int = CHUNK_ROWS):
        self.names = list(POSE_COLUMNS)  # MATRIX_COLUMNS when the file gives matrices
        super().__init__(source, fmt, name, chunk_rows)

    def _header(self, fields, line_no):
        # FK output of one link (``tool0.x, ..., tool0.qz``) reads as targets of that link
        prefixes = {f.rpartition(".")[0] for f in fields}
        if len(prefixes) == 1 and prefixes != {""}:
            fields = [f.rpartition(".")[2] for f in fields]
        self.columns = fields
        self.names = list(MATRIX_COLUMNS if any(f in MATRIX_COLUMNS for f in fields) else POSE_COLUMNS)
        return _column_permutation(fields, self.names, f"{self.name}: line {line_no} (header)", "column",
                                   f"the columns are {_TARGET_COLUMNS}")

    def _no_header(self, fields, line_no):
        if len(fields) not in (len(POSE_COLUMNS), len(MATRIX_COLUMNS)):
            raise TrajectoryFileError(f"{self.name}: line {line_no}: expected 7 columns ({', '.join(POSE_COLUMNS)}) "
                                      f"or 16 ({self.many_columns}), got {len(fields)}")
        self.names = list(POSE_COLUMNS if len(fields) == len(POSE_COLUMNS) else MATRIX_COLUMNS)

    def _npy_rows(self, arr):
        if arr.ndim == 3 and arr.shape[1:] == (4, 4):
            self.names = list(MATRIX_COLUMNS)
            return arr.reshape(arr.shape[0], 16)
        if arr.ndim == 2 and arr.shape[1] == len(POSE_COLUMNS):
            return arr
        raise TrajectoryFileError(f"{self.name}: expected an array of shape (N, 4, 4) (poses T_world_link) or (N, 7) "
                                  f"({', '.join(POSE_COLUMNS)}), got shape {arr.shape}")

    def _json_row(self, obj, where, line_no):
        if isinstance(obj, list) and (len(obj) == len(POSE_COLUMNS) or not obj or not isinstance(obj[0], (list, dict))):
            if len(obj) != len(POSE_COLUMNS):
                raise TrajectoryFileError(f"{where}: expected 7 numbers ({', '.join(POSE_COLUMNS)}) or a pose, "
                                          f"got a list of {len(obj)}")
            return self._numbers(obj, where)
        if isinstance(obj, (dict, list)):
            try:
                T, is_batch = pose_list(obj, "target")
            except PoseError as exc:
                raise TrajectoryFileError(f"{where}: {exc}") from None
            if is_batch:
                raise TrajectoryFileError(f"{where}: one pose per line, got a list of {len(T)} poses")
            return pose_rows(T)[0].tolist()
        raise TrajectoryFileError(f"{where}: expected a pose: a list of 7 numbers ({', '.join(POSE_COLUMNS)}), a 4x4 "
                                  "matrix, {\"position\", \"quaternion\"} or {\"xyz\", \"rpy\"}")

    def _check(self, A, row_of, col_of):
        super()._check(A, row_of, col_of)
        if A.shape[1] == len(POSE_COLUMNS):
            norm = np.linalg.norm(A[:, 3:], axis=1)
            bad = np.flatnonzero(np.abs(norm - 1.0) > RIGID_TOLERANCE)
            if bad.size:
                k = int(bad[0])
                cols = ", ".join(str(col_of(j) + 1) for j in range(3, 7))
                raise TrajectoryFileError(f"{self.name}: {row_of(k)}, columns {cols} (qw, qx, qy, qz): "
                                          f"not a unit quaternion (norm {norm[k]:.9g})")
            return
        for k, T in enumerate(A.reshape(-1, 4, 4)):
            if not is_rigid_transform(T, RIGID_TOLERANCE):
                raise TrajectoryFileError(f"{self.name}: {row_of(k)}: not a rigid transform (rotation orthonormal "
                                          "with det 1, last row 0 0 0 1)")

    def _chunk(self, A):
        if A.shape[1] != len(POSE_COLUMNS):
            return A.reshape(-1, 4, 4)
        quat = A[:, 3:] / np.linalg.norm(A[:, 3:], axis=1, keepdims=True)
        T = np.zeros((A.shape[0], 4, 4))
        T[:, :3, :3] = np.moveaxis(quaternion_to_matrix(*quat.T), -1, 0)
        T[:, :3, 3] = A[:, :3]
        T[:, 3, 3] = 1.0
        return T


def fk_table(T: np.ndarray) -> np.ndarray:
    """(n, L, 4, 4) poses -> (n, 7 L) rows of ``x, y, z, qw, qx, qy, qz`` per link."""
    n, L = T.shape[:2]
    out = np.empty((n, L, 7))
    out[..., :3] = T[..., :3, 3]
    out[..., 3:] = matrix_to_quaternion(T[..., :3, :3])
    return out.reshape(n, 7 * L)


def require_joint_columns(model: RobotModel) -> None:
    """Refuse, naming why, a model whose q is not one column per joint: no moving joint, or a
    floating or planar joint (several values per joint: the library and the service take those)."""
    if model.dof == 0:
        raise TrajectoryFileError(f"model {model.name!r} has no moving joint: there is no joint value to read")
    if model.multi_dof:
        kinds = sorted({j.type for j in model.joints if j.type in ("floating", "planar")})
        raise TrajectoryFileError(f"model {model.name!r} has {' and '.join(kinds)} joints (several values each): "
                                  "trajectory, Parquet and log files take one column per joint; use the Python "
                                  "library or the service for this model")


def pose_rows(T: np.ndarray) -> np.ndarray:
    """(n, 4, 4) poses -> (n, 7) rows ``x, y, z, qw, qx, qy, qz`` (``qw >= 0``)."""
    return fk_table(np.asarray(T, dtype=np.float64)[:, None])


def _looks_like_header(fields: list[str]) -> bool:
    """A first CSV line is a header when any of its fields is not a number."""
    for f in fields:
        try:
            float(f)
        except ValueError:
            return True
    return False


def _column_permutation(fields: list[str], names: list[str], where: str, what: str, known: str,
                        hint=lambda field: "") -> np.ndarray:
    """Column of the file holding each of ``names``, from the header ``fields`` (``what`` the kind of
    column in messages, ``known`` what the columns may be, ``hint(field)`` said of an unknown one)."""
    index = set(names)
    seen: dict[str, int] = {}
    for c, f in enumerate(fields):
        if f not in index:
            raise TrajectoryFileError(f"{where}, column {c + 1}: unknown {what} {f!r}{hint(f)}; {known}")
        if f in seen:
            raise TrajectoryFileError(f"{where}, column {c + 1}: {what} {f!r} repeats column {seen[f] + 1}")
        seen[f] = c
    missing = [n for n in names if n not in seen]
    if missing:
        raise TrajectoryFileError(f"{where}: no column for {what}(s) {', '.join(missing)}")
    return np.array([seen[n] for n in names], dtype=np.intp)


def _nth_data_line(raw: list[str], first_line: int, k: int) -> int:
    """Line number of the k-th (0-based) non-blank line of ``raw``, which starts at ``first_line``."""
    n = -1
    for i, line in enumerate(raw):
        if line.strip():
            n += 1
            if n == k:
                return first_line + i
    raise IndexError(k)  # pragma: no cover - k always indexes a parsed line


def _open_npy(source, name: str, what: str) -> np.ndarray:
    """A numeric ``.npy`` array, memory-mapped (its shape is the caller's to check)."""
    try:
        arr = np.load(source, mmap_mode="r", allow_pickle=False)
    except ValueError as exc:  # object arrays, bad header
        raise TrajectoryFileError(f"{name}: cannot read as .npy: {exc}") from None
    except (OSError, EOFError) as exc:
        raise TrajectoryFileError(f"{name}: cannot read as .npy: {getattr(exc, 'strerror', None) or exc}") from None
    if not isinstance(arr, np.ndarray):
        raise TrajectoryFileError(f"{name}: not a single .npy array (an .npz archive?)")
    if arr.dtype.kind not in "fiu":
        raise TrajectoryFileError(f"{name}: {what} must be numbers, the array has dtype {arr.dtype}")
    return arr


def _open_rows(path, fmt: str | None, chunk_rows: int, make):
    """``make(source, fmt, name, chunk_rows)`` for a path (format by extension) or a text stream."""
    if isinstance(path, (str, os.PathLike)):
        return make(path, format_of(path, fmt), str(path), chunk_rows)
    fmt = fmt or "csv"
    if fmt == "npy":
        raise TrajectoryFileError(".npy input must be a file, not a stream")
    return make(path, fmt, getattr(path, "name", "<stream>"), chunk_rows)


def open_joint_rows(path, model: RobotModel, fmt: str | None = None, chunk_rows: int = CHUNK_ROWS) -> JointRows:
    """Open a trajectory file (a path, or a text stream for ``csv``/``jsonl``) for chunked reading."""
    return _open_rows(path, fmt, chunk_rows, lambda src, f, name, n: JointRows(src, model, f, name, n))


def open_state_rows(path, model: RobotModel, fmt: str | None = None, chunk_rows: int = CHUNK_ROWS) -> StateRows:
    """Open a file of joint values and velocities (a path, or a text stream for ``csv``/``jsonl``)."""
    return _open_rows(path, fmt, chunk_rows, lambda src, f, name, n: StateRows(src, model, f, name, n))


def open_target_rows(path, fmt: str | None = None, chunk_rows: int = CHUNK_ROWS) -> TargetRows:
    """Open a file of target poses (a path, or a text stream for ``csv``/``jsonl``) for chunked reading."""
    return _open_rows(path, fmt, chunk_rows, TargetRows)
