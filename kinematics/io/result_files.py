"""Streaming writers of result files: poses, Jacobians, IK answers and velocities out, in
chunks that match the chunks of :mod:`kinematics.io.trajectory`'s readers; and a uniform
sample of the rows of a stream (:class:`RowSampler`).

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
- IK, ``csv``: the joint names (the answer ``q``), then ``success`` (``true``/``false``),
  ``position_error`` (metres), ``rotation_error`` (radians) and ``iterations``.
- IK, ``npy``: ``q`` only, (N, dof); ``jsonl``: per row ``{"q": {joint: value}, "success",
  "position_error", "rotation_error", "iterations"}``.
- Velocities (input :class:`StateRows`: joint values then joint velocities per row, CSV header
  ``<joint>`` and ``<joint>.qdot``), ``csv``: per link ``<link>.vx, .vy, .vz, .wx, .wy, .wz``, the
  link's twist in one reference (linear part first); ``npy``: (N, L, 6); ``jsonl``: per row
  ``{"twists": {link: [vx, vy, vz, wx, wy, wz]}}``.

Floats are written so they read back exactly (shortest round-trip repr in text formats).
The ``.npy`` writer streams: it reserves a fixed-size header, appends each chunk, and
writes the final row count into the header when it is closed, so the row count need not
be known in advance (``numpy.lib.format.open_memmap`` needs it up front).
"""

from __future__ import annotations

import io
import json
import os
import tempfile

import numpy as np

from .pose_records import pose_output
from .trajectory import TrajectoryFileError, fk_table

#: bytes reserved for the header of a streamed .npy file (magic and length included);
#: a multiple of 64 as numpy aligns it, and room for any shape.
NPY_HEADER_BYTES = 256


# ============================================================================ writers
def fk_columns(links) -> list[str]:
    """CSV column names of FK output: per link ``x, y, z, qw, qx, qy, qz``."""
    return [f"{l}.{c}" for l in links for c in ("x", "y", "z", "qw", "qx", "qy", "qz")]


def jacobian_columns(dof: int) -> list[str]:
    """CSV column names of Jacobian output: ``J<r><c>`` row-major, r in 0..5, c in 0..dof-1."""
    return [f"J{r}{c}" for r in range(6) for c in range(dof)]


#: CSV column suffixes of velocity output, per link: the twist, linear part first
TWIST_COLUMNS = ("vx", "vy", "vz", "wx", "wy", "wz")


def velocity_columns(links) -> list[str]:
    """CSV column names of velocity output: per link ``<link>.vx ... <link>.wz``."""
    return [f"{l}.{c}" for l in links for c in TWIST_COLUMNS]


#: CSV columns of IK output after the joint values
IK_STATUS_COLUMNS = ("success", "position_error", "rotation_error", "iterations")


def ik_columns(joint_names) -> list[str]:
    """CSV column names of IK output: the joint names, then :data:`IK_STATUS_COLUMNS`."""
    return list(joint_names) + list(IK_STATUS_COLUMNS)


class AtomicOutput:
    """The ``with`` protocol of the output writers: finished (:meth:`close`, which renames the
    temporary file into place) when the block ends normally, dropped (:meth:`abort`) on an
    exception, so a destination never holds half an answer."""

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


def part_file(dest: str, name: str) -> tuple[int, str]:
    """``(fd, path)`` of a new temporary file beside ``dest`` (``.<basename>.*.part``), with the
    usual permissions; an unwritable folder is a :class:`TrajectoryFileError` naming ``name``."""
    folder = os.path.dirname(os.path.abspath(dest))
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{os.path.basename(dest)}.", suffix=".part", dir=folder)
    except OSError as exc:
        raise TrajectoryFileError(f"{name}: cannot write: {exc.strerror or exc}") from None
    os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the usual permissions
    return fd, tmp


def drop_file(path: str) -> None:
    """Remove a partial output (already gone is fine)."""
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


class ResultWriter(AtomicOutput):
    """Writes result chunks to a file (atomically: a temporary file renamed on success) or a stream.

    ``kind`` is ``fk`` (chunks (n, L, 4, 4), ``labels`` the link names), ``jacobian``
    (chunks (n, 6, dof), ``labels`` the joint names) or ``ik`` (chunks are IK solutions: objects
    with ``q`` (n, dof), ``success``, ``position_error``, ``rotation_error`` and ``iterations``
    (n,); ``labels`` the joint names), or ``velocity`` (chunks (n, L, 6) twists, ``labels`` the
    link names). Use as a context manager: on an exception the partial
    file is removed and the destination left untouched.
    """

    def __init__(self, dest, fmt: str, kind: str, labels, name: str | None = None):
        if kind not in ("fk", "jacobian", "ik", "velocity"):
            raise ValueError(kind)
        self.fmt, self.kind, self.labels = fmt, kind, list(labels)
        self.rows = 0
        self._tmp: str | None = None
        self._dest: str | None = None
        if isinstance(dest, (str, os.PathLike)):
            self._dest = str(dest)
            self.name = name or self._dest
            fd, self._tmp = part_file(self._dest, self.name)
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
            if self.kind == "fk":
                cols = fk_columns(self.labels)
            elif self.kind == "velocity":
                cols = velocity_columns(self.labels)
            else:
                cols = jacobian_columns(len(self.labels)) if self.kind == "jacobian" else ik_columns(self.labels)
            self._fh.write(",".join(cols) + "\n")

    def write(self, chunk) -> None:
        """Append a chunk of results: (n, L, 4, 4) for FK, (n, 6, dof) for Jacobians, an IK solution
        for IK (``.npy`` output holds its ``q`` only)."""
        solution = None
        if self.kind == "ik":
            solution, chunk = chunk, chunk.q
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
            if solution is None:
                buf.writelines(",".join(map(repr, row)) + "\n" for row in table.tolist())
            else:
                buf.writelines(f"{','.join(map(repr, row))},{'true' if ok else 'false'},{p!r},{r!r},{it}\n"
                               for row, ok, p, r, it in zip(table.tolist(), *_ik_status(solution)))
            self._fh.write(buf.getvalue())
        else:
            records = self._json_records(chunk) if solution is None else self._ik_records(chunk, solution)
            self._fh.write("".join(json.dumps(rec, allow_nan=True, default=np.ndarray.tolist) + "\n" for rec in records))
        self.rows += n

    def _json_records(self, chunk: np.ndarray):
        if self.kind == "velocity":
            for twists in chunk.tolist():
                yield {"twists": dict(zip(self.labels, twists))}
            return
        if self.kind == "jacobian":
            for J in chunk:
                yield {"jacobian": J.tolist()}
            return
        for poses in pose_output(chunk, self.labels):
            yield {"poses": poses}

    def _ik_records(self, Q: np.ndarray, solution):
        for q, ok, p, r, it in zip(Q.tolist(), *_ik_status(solution)):
            yield {"q": dict(zip(self.labels, q)), "success": ok, "position_error": p, "rotation_error": r,
                   "iterations": it}

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
                    L = len(self.labels)
                    tail = {"fk": (L, 4, 4), "jacobian": (6, L), "ik": (L,), "velocity": (L, 6)}[self.kind]
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
                drop_file(self._tmp)
                self._tmp = None
        self._fh = None


def _ik_status(solution) -> tuple[list, list, list, list]:
    """``success`` (bools), ``position_error``, ``rotation_error`` (floats), ``iterations`` (ints) of an
    IK solution, as Python lists."""
    return ([bool(s) for s in np.asarray(solution.success).tolist()],
            np.asarray(solution.position_error, dtype=np.float64).tolist(),
            np.asarray(solution.rotation_error, dtype=np.float64).tolist(),
            [int(i) for i in np.asarray(solution.iterations).tolist()])


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
