"""The command line's toolkit: what several commands share (options for files in and out, loading
the model a command names, reading and writing joint and target files, the exit codes of a failure or
a disagreement, timing lines). The commands themselves live beside it, one module each."""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import tempfile
import time

from .. import api
from ..errors import KinematicsError
from ..io.result_files import ResultWriter
from ..io.trajectory import CHUNK_ROWS, FORMATS, TrajectoryFileError, format_of, open_joint_rows, open_target_rows
from ..model.robot import RobotModel
from ..tolerances import AGREEMENT_TOLERANCE
from . import EXIT_DISAGREE, EXIT_MODEL, EXIT_OK
from .progress import progress

#: input formats beyond the trajectory files: Parquet (file, directory or glob) and ROS bags
IN_FORMATS = FORMATS + ("parquet", "rosbag")
#: output formats beyond the trajectory files: Parquet, and MCAP (a TF tree, FK only)
OUT_FORMATS = FORMATS + ("parquet", "mcap")
#: nanoseconds between samples of an MCAP output whose input has no time
UNTIMED_STEP_NS = 10_000_000
#: rows sampled by a bare ``--verify``
DEFAULT_VERIFY_ROWS = 100

EXIT_CODES = """exit codes:
  0  success
  1  --verify found a deviation from Pinocchio above 1e-9
  2  bad usage or bad input: a malformed file (the message names the line or row, the
     column and its joint), an unknown link, an unwritable output
  3  the model could not be loaded (unknown id, invalid URDF or DH table)"""

FORMAT_HELP = """input (INPUT, by extension; '-' reads CSV from standard input):
  .csv     one configuration per line; an optional header of joint names in any order
           (reordered to the model's joint order), else columns in joint_names order
  .npy     numeric array (N, dof), read memory-mapped
  .jsonl   JSON lines: a list of dof numbers, or a {"joint": value} object per line
  .parquet columns named like the joints (any order; others ignored) and an optional time column
           ('time', or --time-column), carried to Parquet/MCAP output; a directory or glob of
           Parquet files is read as one dataset
  .bag .db3 .mcap  ROS 1 / ROS 2 bags (or a ROS 2 bag directory): sensor_msgs/JointState of
           --topic (default: the first JointState topic), joints mapped by name per message;
           a message without a model joint is an error (or skipped: --skip-incomplete); the
           time is the header stamp (ns)
output (-o, by extension): .csv .npy .jsonl; .parquet (time column first, then per link
  <link>.x ... <link>.qz, or J<r><c>); .mcap (fk only: tf2_msgs/TFMessage on /tf, every link,
  for Foxglove; --pose-topics adds geometry_msgs/PoseStamped per link)
  Error messages count CSV/JSON lines from 1 (as an editor does) and .npy rows from 0."""


class ModelLoadError(Exception):
    """The model named on the command line cannot be loaded (exit code 3)."""


# ============================================================================ options
def io_options(p: argparse.ArgumentParser, what: str = "joint values", verify: bool = True) -> None:
    """INPUT (``what`` it holds), -o OUTPUT, formats, --chunk and (``verify``) --verify K / --seed."""
    p.add_argument("input", metavar="INPUT", help=f"{what}: .csv, .npy or .jsonl ('-': CSV on stdin)")
    p.add_argument("-o", "--output", metavar="OUTPUT", default="-",
                   help="results file: .csv, .npy or .jsonl by extension (default: CSV on stdout)")
    p.add_argument("--input-format", choices=IN_FORMATS, help="format of INPUT when its extension does not tell")
    p.add_argument("--output-format", choices=OUT_FORMATS, help="format of OUTPUT when its extension does not tell")
    p.add_argument("--time-column", metavar="NAME", help="Parquet input: the time column (default 'time' when present)")
    if verify:
        p.add_argument("--verify", nargs="?", type=int, const=DEFAULT_VERIFY_ROWS, default=None, metavar="K",
                       help=f"compare K randomly sampled rows (default {DEFAULT_VERIFY_ROWS}) with Pinocchio; "
                       f"print the largest deviations to stderr; exit 1 above {AGREEMENT_TOLERANCE:g} "
                       "(write --verify=K, or put --verify after INPUT)")
        p.add_argument("--seed", type=int, default=0, help="seed of the --verify sample (default 0)")
    p.add_argument("--chunk", type=int, default=CHUNK_ROWS, metavar="ROWS",
                   help=f"rows per chunk (default {CHUNK_ROWS}); bounds the memory used")


# ============================================================================ helpers
def load_model(args) -> RobotModel:
    """The model named by ``--model``, ``--urdf``, ``--dh``, ``--xacro`` (with ``--arg``, ``--package-path``)
    or ``--mjcf`` (raises :class:`ModelLoadError`)."""
    xacro, mjcf = getattr(args, "xacro", None), getattr(args, "mjcf", None)
    xargs = {}
    for item in getattr(args, "arg", None) or ():
        name, sep, value = item.partition("=")
        if not sep or not name:
            raise ModelLoadError(f"--arg {item!r} is not NAME=VALUE")
        xargs[name] = value
    try:
        return api.load_model(model_id=args.model, urdf=args.urdf, dh=args.dh, xacro=xacro, mjcf=mjcf,
                              args=xargs or None, package_paths=getattr(args, "package_path", None) or ())
    except OSError as exc:
        path = exc.filename or args.urdf or args.dh or xacro or mjcf
        raise ModelLoadError(f"cannot read {path}: {exc.strerror or exc}") from None
    except KinematicsError as exc:
        raise ModelLoadError(str(exc)) from None


def resolve_links(model: RobotModel, spec: list[str] | None) -> list[str]:
    if not spec:
        return api.resolve_links(model, None)
    names = [n.strip() for s in spec for n in s.split(",") if n.strip()]
    if names == ["all"]:
        return api.resolve_links(model, "all")
    if "all" in names:
        raise TrajectoryFileError("--links all cannot be combined with link names")
    api.resolve_links(model, names)  # raises UnknownLinkError naming the link
    return names


def fail(command: str, message: str, code: int) -> int:
    print(f"kinematics {command}: error: {message}", file=sys.stderr)
    return code


def model_or_exit_code(args, command: str) -> RobotModel | int:
    """The model the options name (:func:`load_model`), or the exit code of a model that cannot be loaded,
    after saying why."""
    try:
        return load_model(args)
    except ModelLoadError as exc:
        return fail(command, str(exc), EXIT_MODEL)


@contextlib.contextmanager
def atomic_file(path: str, prefix: str):
    """A binary file whose content replaces ``path`` (mode 0644) only when the ``with`` block ends
    normally: until then a temporary file ``<prefix>*`` beside it, removed on an exception."""
    fd, tmp = tempfile.mkstemp(prefix=prefix, dir=os.path.dirname(os.path.abspath(path)))
    try:
        with os.fdopen(fd, "wb") as fh:
            yield fh
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def parse_point(text: str | None) -> list[float] | None:
    """``--point X,Y,Z`` (metres, the link frame) as three numbers (None without it); a ValueError
    naming the option otherwise."""
    if text is None:
        return None
    try:
        point = [float(v) for v in text.split(",")]
    except ValueError:
        point = []
    if len(point) != 3:
        raise ValueError(f"--point: {text!r}; give three comma-separated numbers x,y,z")
    return point


def verification_due(command: str, args, sampler, outside: int, n: int) -> bool:
    """After a streamed run of ``n`` configurations: the note on those outside their limits, and whether
    a sample is to be verified now (``--verify`` given and the sampler holds rows; none: said so)."""
    if outside:
        print(f"{command}: note: {outside} of {n} configurations have joint values outside the joint limits "
              "(computed anyway)", file=sys.stderr)
    if args.verify is None:
        return False
    if sampler.Q is None:
        print(f"{command}: verify: no configuration to check", file=sys.stderr)
        return False
    return True


def quietly(run, *args) -> int:
    """``run(*args)``, stopping quietly when the reader of stdout goes away (e.g. `| head`)."""
    try:
        return run(*args)
    except BrokenPipeError:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return EXIT_OK


def endpoints(args) -> tuple:
    """``(source, input format, destination, output format)`` of INPUT and -o OUTPUT ('-': stdin, stdout)."""
    in_fmt = "csv" if args.input == "-" and args.input_format is None else args.input_format
    out_fmt = "csv" if args.output == "-" and args.output_format is None else args.output_format
    if in_fmt is None:
        from ..io.logs import is_log
        from ..io.parquet import is_parquet

        in_fmt = "parquet" if is_parquet(args.input) else "rosbag" if is_log(args.input) else None
    if out_fmt is None:
        ext = os.path.splitext(str(args.output))[1].lower()
        out_fmt = "parquet" if ext in (".parquet", ".pq") else "mcap" if ext == ".mcap" else None
    if out_fmt in ("parquet", "mcap") and args.output == "-":
        raise TrajectoryFileError(f"{out_fmt} output must go to a file (-o FILE)")
    if in_fmt in ("parquet", "rosbag") and args.input == "-":
        raise TrajectoryFileError(f"{in_fmt} input must be a file")
    if out_fmt not in ("parquet", "mcap"):
        out_fmt = format_of(args.output, out_fmt)
    source = sys.stdin if args.input == "-" else args.input
    dest = sys.stdout if args.output == "-" else args.output
    return source, in_fmt, dest, out_fmt


def timing(command: str, n: int, noun: str, args, elapsed: float) -> None:
    """On a terminal, how many rows went where, and how fast."""
    if sys.stderr.isatty():
        where = "stdout" if args.output == "-" else args.output
        print(f"{command}: {n} {noun} -> {where} in {elapsed:.2f} s ({n / max(elapsed, 1e-9):,.0f}/s)", file=sys.stderr)


def open_input(args, model: RobotModel, source, in_fmt: str | None, targets: bool = False):
    """The chunked reader of INPUT: Parquet (file, directory, glob), a ROS bag, or a trajectory file
    (joint values, or target poses when ``targets``). Readers with a time column set ``times``."""
    if in_fmt == "parquet":
        from ..io.parquet import ParquetJointRows, ParquetTargetRows

        from ..engine.parallel import thread_count

        rows = (ParquetTargetRows(source, args.chunk, time_column=args.time_column) if targets else
                ParquetJointRows(source, model, args.chunk, time_column=args.time_column))
        rows.use_threads = thread_count() > 1
        return rows
    if in_fmt == "rosbag":
        if targets:
            raise TrajectoryFileError("a ROS bag holds joint states, not target poses")
        from ..io.logs import open_log

        return open_log(source, model, topic=getattr(args, "topic", None),
                        skip_incomplete=getattr(args, "skip_incomplete", False), chunk_rows=args.chunk)
    if targets:
        return open_target_rows(source, in_fmt, args.chunk)
    return open_joint_rows(source, model, in_fmt, args.chunk)


def open_output(args, dest, out_fmt: str, kind: str, labels, model: RobotModel, rows):
    """The writer of OUTPUT (``write(result, times)``): Parquet (with the input's time column), MCAP
    (a TF tree; FK of every link only), or a trajectory file (times dropped)."""
    time_field = getattr(rows, "time_field", None)
    if out_fmt == "parquet":
        from ..io.parquet import ParquetResultWriter

        return ParquetResultWriter(dest, kind, labels, time_field=time_field)
    if out_fmt == "mcap":
        if kind != "fk":
            raise TrajectoryFileError(f"MCAP output is a TF tree of FK poses; write {kind} results to .parquet, .csv, "
                                      ".npy or .jsonl")
        from ..io.logs import TFWriter

        return TFWriter(dest, model, pose_topics=getattr(args, "pose_topics", False))
    return _Untimed(ResultWriter(dest, out_fmt, kind, labels))


class _Untimed:
    """A trajectory-file writer taking (and dropping) the times of a chunk."""

    def __init__(self, writer):
        self.writer = writer

    def __enter__(self):
        self.writer.__enter__()
        return self

    def __exit__(self, *exc):
        return self.writer.__exit__(*exc)

    @property
    def rows(self) -> int:
        return self.writer.rows

    def write(self, chunk, times=None) -> None:
        self.writer.write(chunk)


def chunk_times(rows, start: int, n: int):
    """The times of the chunk just read (the reader's ``times``), or ``start + i`` steps of
    :data:`UNTIMED_STEP_NS` when the input has none."""
    times = getattr(rows, "times", None)
    if times is None:
        import numpy as np

        return (start + np.arange(n, dtype=np.int64)) * UNTIMED_STEP_NS
    return times


def stream_option_problem(args) -> str | None:
    """What is wrong with ``--chunk`` or ``--verify K`` of a streamed command (:func:`io_options`), or None."""
    if args.chunk < 1:
        return "--chunk must be positive"
    if args.verify is not None and args.verify < 1:
        return "--verify needs a positive number of rows"
    return None


def verdict(command: str, worst: float) -> int:
    if worst > AGREEMENT_TOLERANCE:
        print(f"{command}: verify: FAIL: deviation {worst:.3g} exceeds {AGREEMENT_TOLERANCE:g}", file=sys.stderr)
        return EXIT_DISAGREE
    return EXIT_OK
