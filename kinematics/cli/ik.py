"""``kinematics ik``: inverse kinematics of every target pose of a file.

Targets (CSV ``x,y,z,qw,qx,qy,qz``, ``.npy`` (N, 4, 4) or (N, 7), JSON lines of poses; see
:class:`kinematics.io.trajectory.TargetRows`) stream in chunks through :func:`kinematics.usecases.ik`;
the answers (joint values, success, errors, iterations) go to OUTPUT, and one summary line to
stderr. The exit code is 1 when any target was not solved. ``--all`` writes every solution, one
row per solution with its target's index (:mod:`kinematics.algorithms.ik_all`).
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time

import numpy as np

from .. import api
from ..usecases import Query
from ..usecases.ik_all import parse_locked as read_locked
from ..algorithms.ik import IK_MODES, MIN_TOLERANCE
from ..usecases.ik_options import DEFAULT_SETTINGS, CollisionAvoidance, IKOptions, IKSettings, SolutionSet
from ..errors import JointValueError
from .collision import add_filter_options, user_pairs
from ..tolerances import AGREEMENT_TOLERANCE
from . import EXIT_DISAGREE, EXIT_OK, EXIT_USAGE, add_command
from .common import (chunk_times, endpoints, fail, io_options, model_or_exit_code, open_input, open_output, quietly,
                     timing)
from .progress import bar_steps, progress

#: failed targets named on stderr at most
SHOW_FAILED = 10

TARGET_HELP = """targets (INPUT, by extension; '-' reads CSV from standard input), T_world_link of --link:
  .csv     x,y,z,qw,qx,qy,qz per line (metres; unit quaternion, w first), or the 16 entries of the
           4x4 matrix row-major; an optional header names the columns in any order (x ... qz or
           T00 ... T33; a common prefix like 'tool0.', as `kinematics fk` output has, is dropped)
  .npy     (N, 4, 4) matrices or (N, 7) rows x,y,z,qw,qx,qy,qz
  .jsonl   per line [x,y,z,qw,qx,qy,qz], a 4x4 matrix, {"position": [x,y,z], "quaternion":
           {"w","x","y","z"}} or {"xyz": [..], "rpy": [..]}
  Quaternions must be unit to 1e-6 and matrices rigid. Error messages count CSV/JSON lines from
  1 and .npy rows from 0.

output (-o, by extension; CSV on stdout by default):
  .csv     the joint names (the answer q), then success (true/false), position_error (m),
           rotation_error (rad), iterations
  .npy     q only, (N, dof)
  .jsonl   {"q": {joint: value}, "success", "position_error", "rotation_error", "iterations"}"""

EXIT_CODES = """exit codes:
  0  every target solved
  1  a target was not solved (its row has success false and the best answer found), or
     --verify found a solved answer off its target by more than the tolerance + 1e-9
  2  bad usage or bad input: a malformed file (the message names the line or row and the
     column), a non-unit quaternion, an unknown link, an unwritable output
  3  the model could not be loaded (unknown id, invalid URDF or DH table)"""


def register(sub) -> None:
    p = add_command(
        sub, "ik", run_ik,
        help="inverse kinematics of every target pose of a file",
        description="Joint values putting --link at each target pose of INPUT (damped least squares "
        "within the joint limits, with random restarts), streamed in chunks. Prints one summary line "
        "to stderr: 'ik: solved S/N targets (X%); worst position error E m, worst rotation error R rad "
        "(of the solved); median iterations M'.",
        epilog=TARGET_HELP + "\n\nexamples:\n"
        "  kinematics ik --model panda --link panda_link8 targets.csv -o q.csv\n"
        "  kinematics ik --model ur5 --link tool0 T.npy -o q.npy --restarts 100 --verify\n"
        "  kinematics ik --dh models/planar_2r.yaml --link tool --mode position xy.csv\n\n"
        + EXIT_CODES,
    )
    p.add_argument("--link", metavar="NAME", help="the link placed at the targets (default: the model's first leaf link)")
    p.add_argument("--mode", choices=IK_MODES, default="pose",
                   help="pose: position and orientation; position: the position only (default pose)")
    add_tolerance_options(p)
    p.add_argument("--max-iterations", type=int, default=DEFAULT_SETTINGS.max_iterations, metavar="N",
                   help=f"steps per attempt (default {DEFAULT_SETTINGS.max_iterations})")
    p.add_argument("--restarts", type=int, default=DEFAULT_SETTINGS.restarts, metavar="N",
                   help=f"random restarts after the first attempt (default {DEFAULT_SETTINGS.restarts})")
    p.add_argument("--random-seed", type=int, default=DEFAULT_SETTINGS.random_seed, metavar="N",
                   help=f"seed of the restarts' draws (default {DEFAULT_SETTINGS.random_seed}; the same inputs give "
                   "the same answers)")
    p.add_argument("--seed", metavar="Q1,Q2,...",
                   help="starting joint values for every target, dof numbers in joint order (default: the "
                   "middle of the limits; write --seed=-0.5,... when the first is negative)")
    io_options(p, what="target poses", verify=False)
    p.add_argument("--verify", action="store_true",
                   help="also measure every answer with Pinocchio's FK; exit 1 when a solved answer is off "
                   f"its target by more than the tolerance + {AGREEMENT_TOLERANCE:g}")
    p.add_argument("--all", action="store_true",
                   help="every solution: one row per solution, 'target' (0-based) first, then the joints, "
                   "position_error, rotation_error, within_limits, singular (.csv or .jsonl output)")
    p.add_argument("--method", choices=("auto", "analytic", "numeric"), default="auto",
                   help="with --all: the chain's closed form (auto, analytic) or the multistart search (numeric)")
    p.add_argument("--limits", choices=("respect", "ignore"), default="respect",
                   help="with --all: respect (every solution inside the limits, 2 pi copies included) or "
                   "ignore (each branch once, angles in (-pi, pi])")
    p.add_argument("--locked", action="append", metavar="JOINT:VALUE", default=[],
                   help="hold a joint at a value (repeat for several; a 7-dof arm with one locked is a 6-joint chain)")
    p.add_argument("--redundancy", metavar="joint:NAME", default=None,
                   help="with --all on a 7-joint chain: the joint whose value runs along the self-motion "
                   "(default: the family's default parameter when --values, --intervals or --select is given)")
    p.add_argument("--values", metavar="V1,V2,...", default=None,
                   help="with --all on a 7-joint chain: every solution at each parameter value (a 'parameter' column)")
    p.add_argument("--intervals", action="store_true",
                   help="with --all on a 7-joint chain: the in-limit ranges of the parameter per target (on stderr, "
                   "one JSON line per target)")
    p.add_argument("--select", choices=("nearest", "margin", "manipulability"), default=None,
                   help="with --all on a 7-joint chain: the one best in-limit solution over the whole self-motion")
    p.add_argument("--dask", metavar="SCHEDULER|local:N",
                   help="with --all: solve on Dask over the partitions of a Parquet INPUT of target poses (file, "
                   "directory or glob): a scheduler address (tcp://host:8786) or local:N worker processes; OUTPUT "
                   "is a directory of Parquet files, the rows of the local CSV (the time column first when INPUT "
                   "has one)")
    add_filter_options(p, "--avoid-collisions", "answers free of self-collision only: with --all the colliding "
                       "solutions are left out; else the search goes on until a free answer is found (success only "
                       "when free)")


def add_tolerance_options(p) -> None:
    """``--position-tolerance`` and ``--rotation-tolerance`` (``kinematics ik``, ``ik-path``)."""
    p.add_argument("--position-tolerance", type=float, default=DEFAULT_SETTINGS.position_tolerance, metavar="M",
                   help=f"metres (default {DEFAULT_SETTINGS.position_tolerance:g})")
    p.add_argument("--rotation-tolerance", type=float, default=DEFAULT_SETTINGS.rotation_tolerance, metavar="RAD",
                   help=f"radians (default {DEFAULT_SETTINGS.rotation_tolerance:g}; ignored in position mode)")


def ik_options(args, wanted: SolutionSet = SolutionSet()) -> IKOptions:
    """The :class:`~kinematics.usecases.ik_options.IKOptions` of a command line (checked by
    :func:`_bad_option` first) asking for ``wanted``, built once for every chunk: the solver's settings
    that the command has (``kinematics ik``: all; ``ik-path``: none, the defaults) and
    ``--avoid-collisions`` with its matrix (:func:`~kinematics.cli.collision.add_filter_options`)."""
    names = [f.name for f in dataclasses.fields(IKSettings)]
    settings = IKSettings(**{name: getattr(args, name) for name in names if hasattr(args, name)})
    collisions = CollisionAvoidance(args.collision_samples, args.collision_cache) if args.avoid_collisions else None
    return IKOptions(settings, wanted, collisions)


def run_ik(args) -> int:
    model = model_or_exit_code(args, "ik")
    if isinstance(model, int):
        return model
    problem = _bad_option(args)
    if problem:
        return fail("ik", problem, EXIT_USAGE)
    if model.dof == 0:
        return fail("ik", f"model {model.name!r} has no moving joint", EXIT_USAGE)
    link = args.link or model.leaf_links[0]
    api.resolve_links(model, [link])  # unknown link: UnknownLinkError (exit 2) before reading anything
    seed = None
    if args.seed is not None:
        try:
            seed, _ = api.joint_batch(model, [float(v) for v in args.seed.split(",")])
        except ValueError:
            return fail("ik", f"--seed: {args.seed!r} is not a comma-separated list of numbers", EXIT_USAGE)
        except JointValueError as exc:
            return fail("ik", f"--seed: {exc}", EXIT_USAGE)
    locked = parse_locked(args.locked)
    if isinstance(locked, str):
        return fail("ik", locked, EXIT_USAGE)
    if args.dask and not args.all:
        return fail("ik", "--dask needs --all", EXIT_USAGE)
    if args.dask:
        return _solve_all_dask(args, model, link, seed, locked)
    if args.all or locked:
        return quietly(_solve_all, args, model, link, seed, locked)
    if redundancy_of(args) is not None:
        return fail("ik", "--redundancy, --values, --intervals and --select need --all", EXIT_USAGE)
    return quietly(_solve, args, model, link, seed)


def parse_locked(items) -> dict[str, float] | str:
    """``--locked JOINT:VALUE`` options as a map, or the message of a malformed one."""
    try:
        return read_locked(items)
    except ValueError as exc:
        return f"--locked: {exc}"


def redundancy_of(args) -> dict | None | str:
    """The ``redundancy`` map of ``--redundancy``, ``--values``, ``--intervals``, ``--select`` (None: none of
    them), or the message of a malformed one."""
    if args.redundancy is None and args.values is None and not args.intervals and args.select is None:
        return None
    spec: dict = {"intervals": bool(args.intervals)}
    if args.redundancy is not None:
        kind, _, name = args.redundancy.partition(":")
        if kind != "joint" or not name:
            return f"--redundancy: {args.redundancy!r} is not joint:NAME"
        spec["parameter"] = {"joint": name}
    if args.values is not None:
        try:
            spec["values"] = [float(v) for v in args.values.split(",")]
        except ValueError:
            return f"--values: {args.values!r} is not a comma-separated list of numbers"
    if args.select is not None:
        spec["select"] = args.select
    return spec


def _solve_all(args, model, link: str, seed, locked) -> int:
    """Every solution of every target: one output row per solution; exit 1 when a target has none."""
    import json

    redundancy = redundancy_of(args)
    if isinstance(redundancy, str):
        return fail("ik", redundancy, EXIT_USAGE)
    extra = ["parameter"] if redundancy is not None else []
    source, in_fmt, dest, out_fmt = endpoints(args)
    if out_fmt not in ("csv", "jsonl"):
        return fail("ik", "--all writes .csv or .jsonl output", EXIT_USAGE)
    api.ik_family(model, link=link, locked=locked)  # a bad --locked fails before any output
    if args.avoid_collisions:  # a model without collision geometry fails before any output too
        from ..usecases.collision import collision_filter

        collision_filter(model, "avoid_collisions", samples=args.collision_samples)
    names = list(model.joint_names)
    query = Query(model, link=link, verify=args.verify,  # the request shape, built once for every chunk
                  collision_pairs=user_pairs(args))
    options = ik_options(args, SolutionSet("all", args.method, locked or None, args.limits, redundancy))
    total = unsolved = rows = colliding = 0
    family = method = "?"
    out = dest if hasattr(dest, "write") else open(dest, "w", encoding="utf-8")
    try:
        if out_fmt == "csv":
            out.write(",".join(["target", *names, "position_error", "rotation_error", "within_limits", "singular",
                                *extra]) + "\n")
        with open_input(args, model, source, in_fmt, targets=True) as targets:
            for start, T in targets:
                a = api.ik(query, T, seed=seed, options=options)
                family, method = a.family, a.method
                for n, ranges in enumerate(getattr(a, "intervals", None) or ()):
                    print(json.dumps({"target": start + n, "intervals": ranges}), file=sys.stderr)
                if a.colliding is not None:
                    colliding += int(a.colliding.sum())
                for n in range(len(a.count)):
                    total += 1
                    unsolved += int(a.count[n] == 0)
                    for rec in a.solutions(n):
                        rows += 1
                        if out_fmt == "csv":
                            out.write(",".join([str(start + n), *(repr(float(v)) for v in rec["q"]),
                                                repr(rec["position_error"]), repr(rec["rotation_error"]),
                                                str(rec["within_limits"]).lower(), str(rec["singular"]).lower(),
                                                *(repr(rec[k]) for k in extra)]) + "\n")
                        else:
                            out.write(json.dumps({"target": start + n, "q": dict(zip(names, rec["q"])),
                                                  **{k: rec[k] for k in ("position_error", "rotation_error",
                                                                         "within_limits", "singular", *extra)}}) + "\n")
                if a.verification is not None:
                    print(f"ik: verify: worst position error {a.verification['max_position_error']:.3g} m, rotation "
                          f"{a.verification['max_rotation_error']:.3g} rad vs {a.verification['reference']}",
                          file=sys.stderr)
    finally:
        if out is not dest:
            out.close()
    left_out = f"; {colliding} solutions left out as in self-collision" if args.avoid_collisions else ""
    print(f"ik: {rows} solutions of {total} targets ({family}, {method}); {unsolved} targets without a solution"
          f"{left_out}", file=sys.stderr)
    return EXIT_DISAGREE if unsolved else EXIT_OK


def _solve_all_dask(args, model, link: str, seed, locked) -> int:
    """``--all --dask``: every solution of every target of a Parquet INPUT, mapped over its partitions
    (:func:`kinematics.distributed.ik_all_dask`); the same rows as the local command's."""
    from .. import distributed
    from ..errors import KinematicsError
    from ..io.parquet import ParquetTargetRows, is_parquet

    if args.input == "-" or not is_parquet(args.input):
        return fail("ik", "--dask reads a Parquet INPUT of target poses (a file, a directory or a glob)", EXIT_USAGE)
    if args.output == "-":
        return fail("ik", "--dask writes a directory of Parquet files: give -o DIRECTORY", EXIT_USAGE)
    if redundancy_of(args) is not None or args.verify:
        return fail("ik", "--redundancy, --values, --intervals, --select and --verify are not available with --dask",
                    EXIT_USAGE)
    try:
        api.ik_family(model, link=link, locked=locked)  # a bad --locked fails before the cluster starts
        with ParquetTargetRows(args.input, time_column=args.time_column) as rows:
            columns, time_column = tuple(rows.names), rows.time_column
        spec = distributed.model_spec(model_id=args.model, urdf=args.urdf, dh=args.dh)
        task = distributed.IKAllTask(link, ik_options(args, SolutionSet("all", args.method, locked or None, args.limits)),
                                     columns, seed=seed, collision_pairs=user_pairs(args), chunk=args.chunk)
        targets, solutions, solved = distributed.run_parquet_ik_all(args.input, args.output, spec, task, address=args.dask,
                                                            time_column=time_column)
    except (KinematicsError, OSError) as exc:
        return fail("ik", str(exc), EXIT_USAGE)
    print(f"ik: {solutions} solutions of {targets} targets on Dask -> {args.output}; {targets - solved} targets "
          "without a solution", file=sys.stderr)
    return EXIT_DISAGREE if solved < targets else EXIT_OK


def _bad_option(args) -> str | None:
    if args.chunk < 1:
        return "--chunk must be positive"
    for option, tol in (("--position-tolerance", args.position_tolerance),
                        ("--rotation-tolerance", args.rotation_tolerance)):
        if not (math.isfinite(tol) and tol >= MIN_TOLERANCE):
            return f"{option} must be a finite number of at least {MIN_TOLERANCE:g}"
    if args.max_iterations < 1:
        return "--max-iterations must be at least 1"
    if args.restarts < 0:
        return "--restarts must be at least 0"
    if args.collision_samples < 1:
        return "--collision-samples must be at least 1"
    return None


def _solve(args, model, link: str, seed) -> int:
    source, in_fmt, dest, out_fmt = endpoints(args)
    summary = _Summary(args)
    query = Query(model, link=link, verify=args.verify,  # the request shape, built once for every chunk
                  collision_pairs=user_pairs(args))
    options = ik_options(args)
    t0 = time.perf_counter()
    with open_input(args, model, source, in_fmt, targets=True) as targets:
        bar = progress(total=targets.total, desc="ik", unit="target", mininterval=0)
        try:
            with open_output(args, dest, out_fmt, "ik", model.joint_names, model, targets) as writer:
                for start, T in targets:
                    times = chunk_times(targets, start, T.shape[0])
                    for s in bar_steps(T.shape[0]):  # parts, so that the bar moves (each target's answer is its own)
                        answer = api.ik(query, T[s], seed=seed, options=options)
                        writer.write(answer.solution, times[s])
                        summary.add(start + s.start, answer)
                        bar.update(s.stop - s.start)
        finally:
            bar.close()
    timing("ik", writer.rows, "targets", args, time.perf_counter() - t0)
    return summary.report()


class _Summary:
    """What the run found, accumulated chunk by chunk in bounded memory."""

    def __init__(self, args):
        self.args = args
        self.pose = args.mode == "pose"
        self.total = self.solved = 0
        self.worst_position = self.worst_rotation = 0.0
        self.iterations: dict[int, int] = {}  # iterations -> how many targets took them
        self.failed: list[int] = []  # the first SHOW_FAILED failed rows
        self.reference = None
        self.verify_position = self.verify_rotation = 0.0
        self.verify_off: list[int] = []  # solved rows Pinocchio puts off target (the first few)
        self.verify_off_count = 0

    def add(self, start: int, answer) -> None:
        sol = answer.solution
        ok = np.asarray(sol.success, dtype=bool)
        n = ok.size
        self.total += n
        self.solved += int(ok.sum())
        if ok.any():
            self.worst_position = max(self.worst_position, float(sol.position_error[ok].max()))
            self.worst_rotation = max(self.worst_rotation, float(sol.rotation_error[ok].max()))
        values, counts = np.unique(np.asarray(sol.iterations, dtype=np.int64), return_counts=True)
        for v, c in zip(values.tolist(), counts.tolist()):
            self.iterations[v] = self.iterations.get(v, 0) + c
        if len(self.failed) < SHOW_FAILED:
            self.failed += (start + np.flatnonzero(~ok)[: SHOW_FAILED - len(self.failed)]).tolist()
        if answer.verification is not None:
            self._add_verification(start, ok, answer.verification)

    def _add_verification(self, start: int, ok: np.ndarray, ver: dict) -> None:
        args = self.args
        self.reference = ver["reference"]
        position, rotation = np.asarray(ver["position_error"]), np.asarray(ver["rotation_error"])
        off = position > args.position_tolerance + AGREEMENT_TOLERANCE
        if self.pose:
            off |= rotation > args.rotation_tolerance + AGREEMENT_TOLERANCE
        off &= ok
        if ok.any():
            self.verify_position = max(self.verify_position, float(position[ok].max()))
            self.verify_rotation = max(self.verify_rotation, float(rotation[ok].max()))
        self.verify_off_count += int(off.sum())
        if len(self.verify_off) < SHOW_FAILED:
            self.verify_off += (start + np.flatnonzero(off)[: SHOW_FAILED - len(self.verify_off)]).tolist()

    def report(self) -> int:
        """Print the verification and the summary line; the exit code."""
        code = EXIT_OK
        failed = self.total - self.solved
        if failed:
            more = ", ..." if failed > len(self.failed) else ""
            print(f"ik: not solved (0-based rows): {', '.join(map(str, self.failed))}{more}", file=sys.stderr)
            code = EXIT_DISAGREE
        if self.args.verify and self.total:
            rotation = f", worst rotation error {self.verify_rotation:.3g} rad" if self.pose else ""
            print(f"ik: verify: {self.solved} solved answers vs {self.reference}: worst position error "
                  f"{self.verify_position:.3g} m{rotation}", file=sys.stderr)
            if self.verify_off_count:
                more = ", ..." if self.verify_off_count > len(self.verify_off) else ""
                print(f"ik: verify: FAIL: {self.verify_off_count} solved answers are off their target by more than "
                      f"the tolerance + {AGREEMENT_TOLERANCE:g} (0-based rows: {', '.join(map(str, self.verify_off))}"
                      f"{more})", file=sys.stderr)
                code = EXIT_DISAGREE
        print(self.line(), file=sys.stderr)
        return code

    def line(self) -> str:
        n, s = self.total, self.solved
        if n == 0:
            return "ik: solved 0/0 targets (no target in the input)"
        percent = math.floor(1000 * s / n) / 10  # 99.9%, never a rounded-up 100%, while one failed
        head = f"ik: solved {s}/{n} targets ({percent:g}%)"
        if s:
            rotation = f", worst rotation error {self.worst_rotation:.3g} rad" if self.pose else ""
            errors = f"worst position error {self.worst_position:.3g} m{rotation} (of the solved)"
        else:
            errors = "no error to report (none solved)"
        return f"{head}; {errors}; median iterations {_median(self.iterations):g}"


def _median(counts: dict[int, int]) -> float:
    """The median of values given as ``{value: how many}``."""
    values = sorted(counts)
    total = sum(counts.values())
    lo_rank, hi_rank = (total - 1) // 2, total // 2  # 0-based ranks of the middle value(s)
    seen, lo = 0, None
    for v in values:
        seen += counts[v]
        if lo is None and seen > lo_rank:
            lo = v
        if seen > hi_rank:
            return 0.5 * (lo + v)
    raise ValueError("no value")  # pragma: no cover - called with at least one target
