"""``kinematics trajectory``: time a path through joint waypoints (one file of waypoints a path).

INPUT is read like the joint values of ``kinematics fk`` (CSV with a header of joint names,
``.npy``, JSON lines, Parquet); each file is one path. OUTPUT by its extension: ``.npz`` (``t``,
``q``, ``qd``, ``qdd``, 0-d ``duration``), ``.csv`` (``t`` and per joint ``q_``, ``qd_``, ``qdd_``
columns), ``.mcap`` (one ``trajectory_msgs/msg/JointTrajectory``) or, without an extension, a new
directory: a ROS 2 bag of that message (as ``ros2 bag record -o NAME``); the last two need the `logs` extra. With several inputs,
OUTPUT is a directory and each result is named after its input (``--format`` gives the kind), with
a progress bar; one line per path to stderr: its duration and method.

A dataset of paths: INPUT a Parquet file, directory or glob with a ``path`` column (``--path-column``)
beside the joint columns; each path id's rows, in order, are its waypoints, and each path lies in
one file. OUTPUT is then a directory of Parquet files, one per input file: the path id, ``t`` and
the ``q_``, ``qd_``, ``qdd_`` columns, one trajectory per path id. ``--dask local:N`` (or a scheduler
address) runs the same on a Dask cluster, one task per file, with the same answers.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from .. import usecases
from ..errors import KinematicsError
from ..usecases.trajectory import INTERPOLATIONS
from ..io import ros_trajectory
from . import EXIT_OK, EXIT_USAGE, add_command
from .common import fail, model_or_exit_code, open_input, quietly
from .progress import progress

FORMATS = ("npz", "csv", "mcap", "bag")


def register(sub) -> None:
    p = add_command(
        sub, "trajectory", run_trajectory, help="time a path through joint waypoints under joint limits",
        description="A trajectory through the waypoints of each INPUT, from rest to rest, time-optimal under "
        "velocity and acceleration limits (and a tool's speed) at every instant, or jerk-limited with --jerk.",
        epilog="example:\n  kinematics trajectory --model ur5 waypoints.csv --acceleration 3 -o trajectory.npz")
    p.add_argument("inputs", nargs="+", metavar="INPUT", help="waypoints: .csv, .npy, .jsonl or .parquet")
    p.add_argument("-o", "--output", required=True, metavar="OUTPUT",
                   help=".npz, .csv, .mcap, or no extension: a ROS 2 bag directory (with several inputs: a directory of results)")
    p.add_argument("--format", choices=FORMATS, help="the kind of OUTPUT (default: its extension)")
    p.add_argument("--input-format", choices=("csv", "npy", "jsonl", "parquet"), help="format of INPUT")
    p.add_argument("--interpolation", choices=INTERPOLATIONS, default="spline")
    p.add_argument("--blend", type=float, default=0.0, metavar="RAD", help="linear: blend radius (0: stop at corners)")
    p.add_argument("--velocity", metavar="V[,V...]", help="rad/s, one or one per joint (default: the model's)")
    p.add_argument("--acceleration", required=True, metavar="A[,A...]", help="rad/s^2, one or one per joint")
    p.add_argument("--jerk", metavar="J[,J...]", help="rad/s^3: a jerk-limited trajectory")
    p.add_argument("--tool-link", metavar="LINK", help="limit this link's linear speed (with --tool-speed)")
    p.add_argument("--tool-speed", type=float, metavar="M/S")
    p.add_argument("--rate", type=float, default=100.0, metavar="HZ", help="samples per second (default 100)")
    p.add_argument("--path-column", default="path", metavar="NAME",
                   help="a Parquet dataset of paths: the column of path ids (default: path)")
    p.add_argument("--dask", metavar="SCHEDULER|local:N",
                   help="a Parquet dataset of paths on a Dask cluster (local:N starts N local workers)")
    p.add_argument("--time-column", default=None, help=argparse.SUPPRESS)
    p.add_argument("--chunk", type=int, default=100_000, help=argparse.SUPPRESS)


def numbers(text: str | None):
    if text is None:
        return None
    values = [float(v) for v in text.split(",")]
    return values[0] if len(values) == 1 else values


def run_trajectory(args) -> int:
    model = model_or_exit_code(args, "trajectory")
    if isinstance(model, int):
        return model
    try:
        tool = None
        if args.tool_link is not None or args.tool_speed is not None:
            if args.tool_link is None or args.tool_speed is None:
                return fail("trajectory", "--tool-link and --tool-speed go together", EXIT_USAGE)
            tool = usecases.ToolSpeed(args.tool_link, args.tool_speed)
        limits = usecases.TrajectoryLimits(numbers(args.velocity), numbers(args.acceleration), numbers(args.jerk), tool)
    except ValueError as exc:
        return fail("trajectory", f"a limit is not a comma-separated list of numbers: {exc}", EXIT_USAGE)
    if args.dask or _dataset_of_paths(args):
        return _run_paths(args, model, limits)
    return quietly(_run, args, model, limits)


def _dataset_of_paths(args) -> bool:
    """Whether INPUT is one Parquet dataset with the path id column."""
    from ..io.parquet import is_parquet, parquet_files

    if len(args.inputs) != 1 or not is_parquet(args.inputs[0]):
        return False
    import pyarrow.parquet as pq

    files = parquet_files(args.inputs[0])
    return bool(files) and args.path_column in pq.ParquetFile(files[0]).schema_arrow.names


def _run_paths(args, model, limits) -> int:
    """A dataset of paths: one trajectory per path id, locally or (``--dask``) on a cluster, written
    as a directory of Parquet files, one per input file (:func:`kinematics.distributed.trajectory_partition`)."""
    from .. import distributed
    from ..io.parquet import WRITE_OPTIONS, is_parquet, parquet_files

    if len(args.inputs) != 1 or not is_parquet(args.inputs[0]):
        return fail("trajectory", "--dask reads one Parquet dataset of paths (a file, a directory or a glob)", EXIT_USAGE)
    if Path(args.output).suffix:
        return fail("trajectory", "a dataset of paths writes a directory of Parquet files: give -o DIRECTORY", EXIT_USAGE)
    task = distributed.TrajectoryTask(limits, args.interpolation, args.blend, args.rate, args.path_column)
    try:
        spec = distributed.model_spec(model_id=args.model, urdf=args.urdf, dh=args.dh)
        if args.dask:
            n = distributed.run_parquet_trajectories(args.inputs[0], args.output, spec, task, address=args.dask)
        else:
            n = _local_paths(args, spec, task, parquet_files(args.inputs[0]), WRITE_OPTIONS)
    except (KinematicsError, OSError) as exc:
        return fail("trajectory", str(exc), EXIT_USAGE)
    print(f"trajectory: {n} paths{' on Dask' if args.dask else ''} -> {args.output}", file=sys.stderr)
    return EXIT_OK


def _local_paths(args, spec, task, files, options) -> int:
    import pyarrow as pa
    import pyarrow.parquet as pq

    from .. import distributed

    tables = [pq.read_table(f, columns=[task.path_column, *distributed.worker_model(spec).joint_names]).to_pandas()
              for f in files]
    distributed.check_paths_apart([t[task.path_column].drop_duplicates().tolist() for t in tables])
    Path(args.output).mkdir(parents=True, exist_ok=True)
    for k, df in enumerate(progress(tables, desc="files", unit="file", disable=None if len(tables) > 1 else True)):
        out = distributed.trajectory_partition(df, spec, task)
        pq.write_table(pa.Table.from_pandas(out, preserve_index=False), Path(args.output) / f"part.{k}.parquet", **options)
    return sum(int(t[task.path_column].nunique()) for t in tables)


def output_kind(path: str, given: str | None) -> str:
    if given:
        return given
    suffix = Path(path).suffix.lower().lstrip(".")
    return "bag" if not suffix else suffix if suffix in FORMATS else "npz"


def write(kind: str, dest: str, ans) -> None:
    arrays = (ans.t, ans.q, ans.qd, ans.qdd)
    if kind == "npz":
        ros_trajectory.write_npz(dest, *arrays, ans.duration)
    elif kind == "csv":
        ros_trajectory.write_csv(sys.stdout if dest == "-" else dest, ans.joint_names, *arrays)
    elif kind == "mcap":
        ros_trajectory.write_mcap(dest, ans.joint_names, *arrays)
    else:
        ros_trajectory.write_bag(dest, ans.joint_names, *arrays)


def _run(args, model, limits) -> int:
    many = len(args.inputs) > 1
    kind = output_kind(args.output, args.format) if not many else (args.format or "npz")
    if many:
        Path(args.output).mkdir(parents=True, exist_ok=True)
    query = usecases.Query(model)
    for source in progress(args.inputs, desc="paths", unit="path", disable=None if many else True):
        with open_input(args, model, source, args.input_format) as rows:
            W = np.concatenate([Q for _, Q in rows])
        ans = usecases.trajectory(query, W, limits, interpolation=args.interpolation, blend=args.blend, rate=args.rate)
        dest = str(Path(args.output) / f"{Path(source).stem}.{kind}") if many else args.output
        write(kind, dest, ans)
        print(f"trajectory: {source}: {len(W)} waypoints, {ans.duration:.6g} s, {len(ans.t)} samples ({ans.method})",
              file=sys.stderr)
    return EXIT_OK
