"""``kinematics ik-path``: a Cartesian path through waypoints, solved by continuation.

Waypoints are read like ``kinematics ik`` targets (CSV ``x,y,z,qw,qx,qy,qz``, ``.npy``, JSON
lines); the rows of joint values go to OUTPUT as CSV (the joint names as header), and one summary
line to stderr: rows, fraction achieved and, where the path stops, the target index and why. The
exit code is 1 when the path is not complete.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from .. import api
from ..algorithms.ik_path import DEFAULT_MAX_JOINT_STEP, DEFAULT_STEP_POSITION, DEFAULT_STEP_ROTATION
from ..algorithms.ik_redundant import OBJECTIVES
from . import EXIT_DISAGREE, EXIT_OK, EXIT_USAGE, add_command
from ..usecases.ik_options import SolutionSet
from .collision import add_filter_options, user_pairs
from .ik import ik_options, parse_locked, redundancy_of
from .common import fail, model_or_exit_code, open_input, quietly


def register(sub) -> None:
    p = add_command(
        sub, "ik-path", run_ik_path, help="a Cartesian path through waypoints that never jumps branches",
        description="Joint values moving --link along straight lines and rotation geodesics through the "
        "waypoints of INPUT, each target the solution nearest the previous row; stops where no solution "
        "is within --max-joint-step and says why.",
        epilog="examples:\n  kinematics ik-path --model ur5 --link tool0 waypoints.csv --seed=0.3,-1,1.2,-0.5,0.8,0.2\n"
        "  kinematics ik-path --model panda --link panda_link8 waypoints.csv --select nearest")
    p.add_argument("input", metavar="INPUT", help="waypoints: .csv, .npy or .jsonl (as `kinematics ik` targets)")
    p.add_argument("-o", "--output", default="-", metavar="OUTPUT", help="CSV of the rows (default stdout)")
    p.add_argument("--input-format", choices=("csv", "npy", "jsonl"), help="format of INPUT")
    p.add_argument("--time-column", help=argparse.SUPPRESS)
    p.add_argument("--chunk", type=int, default=100_000, help=argparse.SUPPRESS)
    p.add_argument("--link", metavar="NAME", help="the link (default: the first leaf link)")
    p.add_argument("--seed", metavar="Q1,Q2,...", help="the start configuration (write --seed=-0.5,... for a negative first)")
    p.add_argument("--step-position", type=float, default=DEFAULT_STEP_POSITION, metavar="M")
    p.add_argument("--step-rotation", type=float, default=DEFAULT_STEP_ROTATION, metavar="RAD")
    p.add_argument("--max-joint-step", type=float, default=DEFAULT_MAX_JOINT_STEP, metavar="RAD")
    p.add_argument("--locked", action="append", metavar="JOINT:VALUE", default=[])
    p.add_argument("--select", choices=OBJECTIVES, default=None,
                   help="a 7-joint chain: move along its self-motion, the parameter chosen continuously at each "
                   "target for this objective (nearest: the least step; margin; manipulability)")
    p.add_argument("--redundancy", metavar="joint:NAME", default=None,
                   help="with --select: the joint whose value runs along the self-motion (default: the family's "
                   "default parameter)")
    p.set_defaults(values=None, intervals=False)  # read by redundancy_of (kinematics ik's options)
    add_filter_options(p, "--avoid-collisions", "stop at the first row in self-collision (reason collision)")


def run_ik_path(args) -> int:
    model = model_or_exit_code(args, "ik-path")
    if isinstance(model, int):
        return model
    locked = parse_locked(args.locked)
    if isinstance(locked, str):
        return fail("ik-path", locked, EXIT_USAGE)
    seed = None
    if args.seed is not None:
        try:
            seed = [float(v) for v in args.seed.split(",")]
        except ValueError:
            return fail("ik-path", f"--seed: {args.seed!r} is not a comma-separated list of numbers", EXIT_USAGE)
    redundancy = redundancy_of(args)
    if isinstance(redundancy, str):
        return fail("ik-path", redundancy, EXIT_USAGE)
    if redundancy is not None and args.select is None:
        return fail("ik-path", "--redundancy needs --select (the objective along the self-motion)", EXIT_USAGE)
    return quietly(_run, args, model, seed, locked, redundancy)


def _run(args, model, seed, locked, redundancy) -> int:
    source = sys.stdin if args.input == "-" else args.input
    fmt = "csv" if args.input == "-" and args.input_format is None else args.input_format
    with open_input(args, model, source, fmt, targets=True) as rows:
        W = np.concatenate([T for _, T in rows])
    ans = api.ik_path(model, W, link=args.link, seed=seed, max_joint_step=args.max_joint_step,
                      collision_pairs=user_pairs(args),
                      step={"position": args.step_position, "rotation": args.step_rotation},
                      options=ik_options(args, SolutionSet(locked=locked or None, redundancy=redundancy)))
    out = sys.stdout if args.output == "-" else open(args.output, "w", encoding="utf-8")
    try:
        out.write(",".join(model.joint_names) + "\n")
        for q in ans.q:
            out.write(",".join(repr(float(v)) for v in q) + "\n")
    finally:
        if out is not sys.stdout:
            out.close()
    stop = "" if ans.stopped is None else f"; stopped at target {ans.stopped['index']}: {ans.stopped['reason']}"
    print(f"ik-path: {len(ans.q)}/{len(ans.targets)} targets, fraction {ans.fraction:.4g}, largest joint step "
          f"{ans.max_joint_step:.3g} ({ans.family}){stop}", file=sys.stderr)
    return EXIT_OK if ans.complete else EXIT_DISAGREE
