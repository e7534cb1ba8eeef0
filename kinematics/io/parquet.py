"""Parquet in and out (``pyarrow``), streamed by record batches so memory stays bounded.

**In** (:class:`ParquetJointRows`): a Parquet file, a directory of them (a partitioned
dataset) or a glob. Joint values are the columns named like the model's joints (any order,
other columns ignored; every joint must have one); a time column (``time`` by default, any
type: integers, floats, timestamps) is read along and carried to the output unchanged. Rows
are read ``chunk_rows`` at a time; a null, non-finite or huge value raises
:class:`~kinematics.io.trajectory.TrajectoryFileError` naming the row (0-based over the whole
dataset) and the joint.

Target poses for IK (:class:`ParquetTargetRows`) are the columns ``x, y, z, qw, qx, qy, qz``
(or with a common prefix, ``tool0.x ...``, as FK output of one link has).

**Out** (:class:`ParquetResultWriter`): one row group per chunk, written to a temporary file
renamed into place on success. Columns: the time column first (when the input had one),
then

- FK: per link ``<link>.x, <link>.y, <link>.z, <link>.qw, <link>.qx, <link>.qy, <link>.qz``
  (position in metres, world frame; unit quaternion, ``qw >= 0``), float64;
- Jacobian: ``J<r><c>`` row-major (r 0..5: linear x, y, z then angular x, y, z; c the joint
  index), float64;
- IK: the joint names (the answer q), ``success`` (bool), ``position_error``,
  ``rotation_error`` (float64), ``iterations`` (int64).

:func:`result_columns` builds those columns from a result chunk; the Dask runner uses it too.

>>> import numpy as np, pyarrow as pa
>>> cols = result_columns("fk", np.eye(4)[None, None], ["tool0"])
>>> list(cols)[:4], cols["tool0.qw"].tolist()
(['tool0.x', 'tool0.y', 'tool0.z', 'tool0.qw'], [1.0])
"""

from __future__ import annotations

import glob as _glob
import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..model.robot import RobotModel
from ..spatial.rotations import quaternion_to_matrix
from ..tolerances import MAX_ABS_COORDINATE, MAX_ABS_JOINT_VALUE, RIGID_TOLERANCE
from .result_files import IK_STATUS_COLUMNS, AtomicOutput, drop_file, fk_columns, jacobian_columns, part_file
from .trajectory import CHUNK_ROWS, POSE_COLUMNS, TrajectoryFileError, fk_table, require_joint_columns

#: default name of the time column (read when present, carried to the output)
TIME_COLUMN = "time"
#: file extensions of Parquet
PARQUET_EXTENSIONS = (".parquet", ".pq")
#: Parquet writer options: no dictionary encoding (poses and Jacobians are all distinct numbers:
#: trying a dictionary per column made writing 5x slower and the file larger), snappy compression
WRITE_OPTIONS = {"use_dictionary": False, "compression": "snappy"}


def _pa():
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:  # pragma: no cover - the `logs` extra
        raise TrajectoryFileError("Parquet needs pyarrow: pip install 'kinematics-service[logs]'") from None
    return pa, pq


def is_parquet(path) -> bool:
    """Whether ``path`` names Parquet: a ``.parquet``/``.pq`` file, a glob of them, or a directory
    holding Parquet files."""
    p = str(path)
    if p.lower().endswith(PARQUET_EXTENSIONS):
        return True
    if os.path.isdir(p):
        return any(f.lower().endswith(PARQUET_EXTENSIONS) for _, _, files in os.walk(p) for f in files)
    return False


def parquet_files(source) -> list[str]:
    """The Parquet files of a file, a directory (recursively, sorted) or a glob."""
    p = str(source)
    if any(c in p for c in "*?["):
        files = sorted(_glob.glob(p, recursive=True))
    elif os.path.isdir(p):
        files = sorted(os.path.join(d, f) for d, _, fs in os.walk(p) for f in fs
                       if f.lower().endswith(PARQUET_EXTENSIONS) and not f.startswith((".", "_")))
    else:
        files = [p]
    if not files:
        raise TrajectoryFileError(f"{p}: no Parquet file")
    return files


class _ParquetRows:
    """Rows of named float columns of a Parquet dataset, in chunks ``(start, block)``; ``times``
    holds the time column of the last chunk (a pyarrow array) or None."""

    what = "values"
    max_abs = MAX_ABS_COORDINATE

    #: let pyarrow decode the columns of a batch on its threads (the CLI turns it on with KIN_THREADS > 1)
    use_threads = False

    def __init__(self, source, chunk_rows: int = CHUNK_ROWS, time_column: str | None = None, name: str | None = None):
        if chunk_rows < 1:
            raise ValueError("chunk_rows must be positive")
        pa, pq = _pa()
        self.name = name or str(source)
        self.chunk_rows = chunk_rows
        self.files = parquet_files(source)
        try:
            # pre_buffer=False: with pyarrow's default (True) iter_batches keeps every buffer it read
            # until the file is closed (memory grew with the length of the file)
            self._pf = [pq.ParquetFile(f, pre_buffer=False, buffer_size=1 << 20) for f in self.files]
        except (OSError, pa.ArrowException) as exc:
            raise TrajectoryFileError(f"{self.name}: cannot read as Parquet: {exc}") from None
        self.schema = self._pf[0].schema_arrow
        self.total = sum(f.metadata.num_rows for f in self._pf)
        fields = list(self.schema.names)
        if time_column is None:
            time_column = TIME_COLUMN if TIME_COLUMN in fields else None
        elif time_column not in fields:
            raise TrajectoryFileError(f"{self.name}: no time column {time_column!r} (columns: {_list(fields)})")
        self.time_column = time_column
        self.time_field = self.schema.field(time_column) if time_column else None
        self.names = self._select(fields)
        self.times = None

    def _select(self, fields: list[str]) -> list[str]:
        """The file columns holding the values, in the order a block has them (or raise)."""
        raise NotImplementedError

    def _label(self, column: str) -> str:
        return column

    def _chunk(self, A: np.ndarray):
        return A

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        for f in self._pf:
            f.close()
        self._pf = []

    def __iter__(self) -> Iterator[tuple[int, np.ndarray]]:
        pa, _ = _pa()
        columns = self.names + ([self.time_column] if self.time_column else [])
        threaded = self.use_threads  # pyarrow decodes the columns on its own threads
        start = 0
        for f, path in zip(self._pf, self.files):
            try:
                for batch in f.iter_batches(batch_size=self.chunk_rows, columns=columns, use_threads=threaded):
                    A = self._block(batch, start)
                    self.times = batch.column(self.time_column) if self.time_column else None
                    yield start, self._chunk(A)
                    start += batch.num_rows
            except pa.ArrowException as exc:
                raise TrajectoryFileError(f"{path}: cannot read as Parquet: {exc}") from None

    def _block(self, batch, start: int) -> np.ndarray:
        n = batch.num_rows
        A = np.empty((n, len(self.names)))
        for j, col in enumerate(self.names):
            arr = batch.column(col)
            if arr.null_count:
                k = int(np.flatnonzero(arr.is_null().to_numpy(zero_copy_only=False))[0])
                raise TrajectoryFileError(f"{self.name}: row {start + k}, column {col!r} ({self._label(col)}): null")
            try:
                A[:, j] = arr.to_numpy(zero_copy_only=False)
            except (TypeError, ValueError):
                raise TrajectoryFileError(f"{self.name}: column {col!r} ({self._label(col)}) has type {arr.type}, "
                                          "not numbers") from None
        bad = ~np.isfinite(A) | (np.abs(A) > self.max_abs)
        if bad.any():
            k, j = map(int, np.argwhere(bad)[0])
            raise TrajectoryFileError(f"{self.name}: row {start + k}, column {self.names[j]!r} "
                                      f"({self._label(self.names[j])}): value {A[k, j]:g} is not finite or beyond "
                                      f"+-{self.max_abs:g}")
        return A


class ParquetJointRows(_ParquetRows):
    """Joint values of a Parquet file, directory or glob, by column name (see the module).

    Iterating yields ``(start, Q)`` as :class:`~kinematics.io.trajectory.JointRows` does;
    ``times`` is then the time column of that chunk (or None), ``time_field`` its schema field.

    >>> import pyarrow as pa, pyarrow.parquet as pq, tempfile, os
    >>> from kinematics.io import default_catalogue
    >>> model = default_catalogue().get("planar_2r")
    >>> path = os.path.join(tempfile.mkdtemp(), "q.parquet")
    >>> pq.write_table(pa.table({"time": [0, 10], "joint_2": [0.5, 0.6], "joint_1": [0.1, 0.2]}), path)
    >>> with ParquetJointRows(path, model) as rows:
    ...     [(start, Q.tolist(), rows.times.to_pylist()) for start, Q in rows]
    [(0, [[0.1, 0.5], [0.2, 0.6]], [0, 10])]
    """

    what = "joint values"
    max_abs = MAX_ABS_JOINT_VALUE

    def __init__(self, source, model: RobotModel, chunk_rows: int = CHUNK_ROWS, time_column: str | None = None,
                 name: str | None = None):
        require_joint_columns(model)
        self.model = model
        super().__init__(source, chunk_rows, time_column, name)

    def _select(self, fields):
        missing = [j for j in self.model.joint_names if j not in fields]
        if missing:
            raise TrajectoryFileError(f"{self.name}: no column for joint(s) {_list(missing)} (columns: {_list(fields)})")
        return list(self.model.joint_names)

    def _label(self, column):
        return f"joint {column!r}"


class ParquetTargetRows(_ParquetRows):
    """Target poses ``T_world_link`` (n, 4, 4) from columns ``x, y, z, qw, qx, qy, qz`` (a common
    prefix such as ``tool0.`` allowed), for IK."""

    what = "targets"

    def _select(self, fields):
        for prefix in [""] + sorted({f.rpartition(".")[0] + "." for f in fields if "." in f}):
            cols = [prefix + c for c in POSE_COLUMNS]
            if all(c in fields for c in cols):
                return cols
        raise TrajectoryFileError(f"{self.name}: expected columns {', '.join(POSE_COLUMNS)} (or <link>.x ... "
                                  f"<link>.qz), got {_list(fields)}")

    def _block(self, batch, start):
        A = super()._block(batch, start)
        check_unit_quaternions(A, self.name, start, self.names)
        return A

    def _chunk(self, A):
        return pose_matrices(A)


def check_unit_quaternions(A: np.ndarray, name: str, start: int, columns) -> None:
    """Refuse a row of ``x, y, z, qw, qx, qy, qz`` (n, 7) whose quaternion is not unit to
    ``RIGID_TOLERANCE``, naming the file, the row (``start`` the first's) and the columns."""
    norm = np.linalg.norm(A[:, 3:], axis=1)
    bad = np.flatnonzero(np.abs(norm - 1.0) > RIGID_TOLERANCE)
    if bad.size:
        raise TrajectoryFileError(f"{name}: row {start + int(bad[0])}, columns {', '.join(list(columns)[3:])}: "
                                  f"not a unit quaternion (norm {norm[bad[0]]:.9g})")


def pose_matrices(A: np.ndarray) -> np.ndarray:
    """Poses (n, 4, 4) of rows ``x, y, z, qw, qx, qy, qz`` (n, 7) (the quaternions normalised)."""
    norm = np.linalg.norm(A[:, 3:], axis=1)
    quat = A[:, 3:] / norm[:, None]
    T = np.zeros((A.shape[0], 4, 4))
    T[:, :3, :3] = np.moveaxis(quaternion_to_matrix(*quat.T), -1, 0)
    T[:, :3, 3] = A[:, :3]
    T[:, 3, 3] = 1.0
    return T


def _list(names, most: int = 12) -> str:
    names = list(names)
    return ", ".join(names) if len(names) <= most else ", ".join(names[:most]) + f", ... ({len(names)} in all)"


# ============================================================================ writer
def result_columns(kind: str, chunk, labels) -> dict[str, np.ndarray]:
    """The output columns (name -> 1-D array) of a result chunk: FK poses (n, L, 4, 4) with
    ``labels`` the links, Jacobians (n, 6, dof) with ``labels`` the joints, or an IK solution
    (``q``, ``success``, ``position_error``, ``rotation_error``, ``iterations``)."""
    labels = list(labels)
    if kind == "ik":
        q = np.asarray(chunk.q, dtype=np.float64)
        cols = {name: np.ascontiguousarray(q[:, k]) for k, name in enumerate(labels)}
        cols[IK_STATUS_COLUMNS[0]] = np.asarray(chunk.success, dtype=bool)
        cols[IK_STATUS_COLUMNS[1]] = np.asarray(chunk.position_error, dtype=np.float64)
        cols[IK_STATUS_COLUMNS[2]] = np.asarray(chunk.rotation_error, dtype=np.float64)
        cols[IK_STATUS_COLUMNS[3]] = np.asarray(chunk.iterations, dtype=np.int64)
        return cols
    chunk = np.asarray(chunk, dtype=np.float64)
    if kind == "fk":
        table, names = fk_table(chunk), fk_columns(labels)
    elif kind == "jacobian":
        table, names = chunk.reshape(chunk.shape[0], 6 * chunk.shape[2]), jacobian_columns(len(labels))
    else:
        raise ValueError(kind)
    T = np.ascontiguousarray(table.T)
    return {name: T[k] for k, name in enumerate(names)}


class ParquetResultWriter(AtomicOutput):
    """Writes result chunks to a Parquet file, one row group per chunk (see the module for the
    columns), atomically: a temporary file renamed on :meth:`close`; on an exception inside a
    ``with`` block the partial file is removed. ``time_field``: the input's time column (a
    pyarrow field), written first from the ``times`` given to :meth:`write`."""

    def __init__(self, dest, kind: str, labels, time_field=None, name: str | None = None):
        if kind not in ("fk", "jacobian", "ik"):
            raise ValueError(kind)
        pa, pq = _pa()
        self.kind, self.labels, self.time_field = kind, list(labels), time_field
        self.rows = 0
        self._dest = str(dest)
        self.name = name or self._dest
        fd, self._tmp = part_file(self._dest, self.name)
        os.close(fd)
        self._writer = None
        self._schema = None

    def _table(self, chunk, times):
        pa, _ = _pa()
        cols = result_columns(self.kind, chunk, self.labels)
        arrays, names = [], []
        if self.time_field is not None:
            if times is None:
                raise ValueError("this writer carries a time column: give the chunk's times")
            arrays.append(times if isinstance(times, (pa.Array, pa.ChunkedArray)) else pa.array(times, self.time_field.type))
            names.append(self.time_field.name)
        arrays += [pa.array(v) for v in cols.values()]
        names += list(cols)
        if self._schema is None:
            fields = ([self.time_field] if self.time_field is not None else []) + \
                     [pa.field(n, a.type) for n, a in zip(names[len(arrays) - len(cols):], arrays[len(arrays) - len(cols):])]
            self._schema = pa.schema(fields)
        return pa.Table.from_arrays(arrays, schema=self._schema)

    def write(self, chunk, times=None) -> None:
        """Append a chunk of results (one row group), with its times when the output has a time column."""
        _, pq = _pa()
        table = self._table(chunk, times)
        if self._writer is None:
            self._writer = pq.ParquetWriter(self._tmp, table.schema, **WRITE_OPTIONS)
        self._writer.write_table(table)
        self.rows += table.num_rows

    def close(self) -> None:
        """Finish the file and rename it into place (an empty result still gets its columns)."""
        if self._tmp is None:
            return
        _, pq = _pa()
        if self._writer is None:
            empty = self._empty()
            self._writer = pq.ParquetWriter(self._tmp, empty.schema, **WRITE_OPTIONS)
            self._writer.write_table(empty)
        self._writer.close()
        os.replace(self._tmp, self._dest)
        self._tmp = None

    def _empty(self):
        L = len(self.labels)
        if self.kind == "ik":
            from types import SimpleNamespace

            chunk = SimpleNamespace(q=np.empty((0, L)), success=np.empty(0, bool), position_error=np.empty(0),
                                    rotation_error=np.empty(0), iterations=np.empty(0, np.int64))
        else:
            chunk = np.empty((0, L, 4, 4)) if self.kind == "fk" else np.empty((0, 6, L))
        pa, _ = _pa()
        times = None if self.time_field is None else pa.array([], self.time_field.type)
        return self._table(chunk, times)

    def abort(self) -> None:
        """Drop the partial file (the destination is left as it was)."""
        if self._writer is not None:
            try:
                self._writer.close()
            except Exception:  # noqa: BLE001 - dropping it anyway
                pass
        if self._tmp is not None:
            drop_file(self._tmp)
            self._tmp = None
