"""``kinematics trajectory``: time a path through joint waypoints (one file of waypoints a path).

INPUT is read like the joint values of ``kinematics fk`` (CSV with a header of joint names,
``.npy``, JSON lines, Parquet); each file is one path. OUTPUT by its extension: ``.npz`` (``t``,
``q``, ``qd``, ``qdd``, 0-d ``duration``), ``.csv`` (``t`` and per joint ``q_``, ``qd_``, ``qdd_``
columns), ``.mcap`` (one ``trajectory_msgs/msg/JointTrajectory``) or, without an extension, a new
directory: a ROS 2 bag of that message (as ``ros2 bag record -o NAME``); the last two need the `logs` extra. With several inputs,
OUTPUT is a directory and each result is named after its input (``--format`` gives the kind), with
a progress bar; one line per path to stderr: its duration and method.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from .. import usecases
from ..usecases.trajectory import INTERPOLATIONS
from ..io import ros_trajectory
from . import EXIT_OK, EXIT_USAGE, add_command
from .pipeline import _fail, _quietly, model_or_exit_code, open_input
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
                return _fail("trajectory", "--tool-link and --tool-speed go together", EXIT_USAGE)
            tool = usecases.ToolSpeed(args.tool_link, args.tool_speed)
        limits = usecases.TrajectoryLimits(numbers(args.velocity), numbers(args.acceleration), numbers(args.jerk), tool)
    except ValueError as exc:
        return _fail("trajectory", f"a limit is not a comma-separated list of numbers: {exc}", EXIT_USAGE)
    return _quietly(_run, args, model, limits)


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
