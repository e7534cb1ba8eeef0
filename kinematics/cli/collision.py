"""``kinematics collision`` and ``kinematics collision-matrix``: self-collision of configurations
from a file, and the allowed-collision matrix as SRDF or JSON.

``collision`` reads joint values (CSV, ``.npy`` or JSON lines, as ``kinematics fk`` does) and
writes a CSV row per configuration: ``row, colliding`` (0/1), ``pairs`` (the link pairs in
collision, ``a|b`` separated by ``;``), with ``--distance`` also ``min_distance, closest``; with
``--per-pair`` a 0/1 column per checked pair instead of ``pairs``. ``collision-matrix`` computes
(or reads back from ``--cache``) the matrix with a progress bar and writes SRDF
(``disable_collisions``; ``-o x.srdf``) or JSON (``-o x.json``).

Both, and the collision-avoiding commands (``ik``, ``ik-path``, ``workspace``), take ``--allow
A,B`` (the pair is not checked: reason ``user``) and ``--forbid A,B`` (the pair is checked even
where the matrix disables it), each repeatable.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import sys

import numpy as np

from ..algorithms.collision_matrix import DEFAULT_SAMPLES, UserPairs
from ..errors import KinematicsError
from ..io.trajectory import open_joint_rows
from ..usecases import collision, collision_matrix
from . import EXIT_OK, EXIT_USAGE, add_command
from .common import fail, model_or_exit_code
from .progress import progress


def register(sub) -> None:
    p = add_command(
        sub, "collision", run_collision,
        help="self-collision of configurations (a flag and the colliding pairs per row)",
        description="Check every configuration of INPUT for self-collision on the pairs the model's "
        "allowed-collision matrix leaves enabled (geometry: the URDF's <collision> elements; meshes of "
        "catalogue models from the installed packages, never from a path an uploaded file names).",
        epilog="examples:\n  kinematics collision --model panda configurations.csv\n"
               "  kinematics collision --model ur5 q.npy --distance --margin 0.01 -o report.csv\n"
               "  kinematics collision --model panda q.csv --allow panda_hand,panda_link5 --forbid panda_link2,panda_link6\n")
    p.add_argument("input", metavar="INPUT", help="joint values: .csv, .npy or .jsonl ('-': CSV on stdin)")
    p.add_argument("-o", "--output", default="-", metavar="CSV", help="the report (default: stdout)")
    p.add_argument("--distance", action="store_true", help="also the minimum distance and the closest pair")
    p.add_argument("--margin", type=float, default=0.0, metavar="M", help="closer than M metres counts as colliding")
    p.add_argument("--per-pair", action="store_true", help="a 0/1 column per checked pair instead of 'pairs'")
    p.add_argument("--dask", metavar="SCHEDULER|local:N",
                   help="run on Dask over the partitions of a Parquet INPUT (file, directory or glob): a scheduler "
                   "address (tcp://host:8786) or local:N worker processes; OUTPUT is a directory of Parquet files "
                   "(colliding, pairs per row, the time column first when INPUT has one)")
    p.add_argument("--time-column", metavar="NAME", help="Parquet INPUT: the time column carried over (default: time, if present)")
    _matrix_options(p)

    m = add_command(
        sub, "collision-matrix", run_collision_matrix,
        help="the allowed-collision matrix (SRDF disable_collisions, or JSON)",
        description="Compute the pairs never checked for self-collision, each with its reason, as MoveIt's "
        "Setup Assistant does: adjacent (parent and child links of a joint), always (in collision in every "
        "sampled configuration), never (in none of N random configurations).",
        epilog="example:\n  kinematics collision-matrix --model panda -o panda.srdf\n")
    m.add_argument("-o", "--output", default="-", metavar="FILE", help=".srdf (default) or .json; '-': SRDF on stdout")
    _matrix_options(m)


def _matrix_options(p) -> None:
    p.add_argument("-n", "--samples", type=int, default=DEFAULT_SAMPLES, metavar="N",
                   help=f"random configurations behind the matrix's never/always pairs (default {DEFAULT_SAMPLES})")
    p.add_argument("--cache", metavar="DIR", default=os.environ.get("KIN_COLLISION_CACHE"),
                   help="keep the matrix in DIR and read it back next time (default $KIN_COLLISION_CACHE)")
    _pair_options(p)


def link_pair(text: str) -> tuple[str, str]:
    """``"a,b"`` -> ``("a", "b")`` (argparse type of ``--allow`` / ``--forbid``)."""
    names = [n.strip() for n in text.split(",")]
    if len(names) != 2 or not all(names):
        raise argparse.ArgumentTypeError(f"{text!r} is not a link pair; give two link names as A,B")
    return names[0], names[1]


def _pair_options(p) -> None:
    p.add_argument("--allow", type=link_pair, action="append", default=[], metavar="A,B",
                   help="do not check the link pair A,B (reason user: a gripper holding a tool); repeatable")
    p.add_argument("--forbid", type=link_pair, action="append", default=[], metavar="A,B",
                   help="check the link pair A,B even where the matrix disables it; repeatable")


def user_pairs(args) -> UserPairs | None:
    """The pairs of ``--allow`` / ``--forbid`` (None: neither given); a pair both allowed and
    forbidden is a :class:`~kinematics.errors.CollisionError`."""
    return UserPairs(tuple(args.allow), tuple(args.forbid)) if args.allow or args.forbid else None


def add_filter_options(p, flag: str, help: str) -> None:
    """``flag`` (collision-free answers only) with the matrix behind it: ``--collision-samples N``,
    ``--collision-cache DIR`` (``kinematics ik``, ``ik-path``, ``workspace``)."""
    p.add_argument(flag, action="store_true", help=help + "; a model without collision geometry is refused")
    p.add_argument("--collision-samples", type=int, default=DEFAULT_SAMPLES, metavar="N",
                   help=f"random configurations behind the allowed-collision matrix (default {DEFAULT_SAMPLES})")
    p.add_argument("--collision-cache", metavar="DIR", default=os.environ.get("KIN_COLLISION_CACHE"),
                   help="keep the matrix in DIR and read it back next time (default $KIN_COLLISION_CACHE)")
    _pair_options(p)


def filter_options(args) -> dict:
    """The use cases' keywords of :func:`add_filter_options`' options (without the flag): the
    matrix's samples and cache, and the query's ``collision_pairs`` when ``--allow`` / ``--forbid``
    name any."""
    options = {"collision_samples": args.collision_samples, "cache_dir": args.collision_cache}
    pairs = user_pairs(args)
    if pairs is not None:
        options["collision_pairs"] = pairs
    return options


def _matrix_with_bar(model, args):
    bar = progress(total=args.samples, desc="collision matrix", unit="cfg")
    done = [0]

    def tick(k: int) -> None:
        bar.update(k - done[0])
        done[0] = k

    try:
        return collision_matrix(model, args.samples, cache_dir=args.cache, progress=tick, collision_pairs=user_pairs(args))
    finally:
        bar.close()


def run_collision_matrix(args) -> int:
    model = model_or_exit_code(args, "collision-matrix")
    if isinstance(model, int):
        return model
    try:
        matrix = _matrix_with_bar(model, args)
    except KinematicsError as exc:
        return fail("collision-matrix", str(exc), EXIT_USAGE)
    text = (json.dumps(matrix.as_dict(), indent=2) + "\n" if args.output.lower().endswith(".json")
            else matrix.to_srdf(model.name))
    if args.output == "-":
        sys.stdout.write(text)
    else:
        with open(args.output, "w", encoding="utf-8") as fh:
            fh.write(text)
    counts = {"user-enabled": len(matrix.forced)} if matrix.forced else {}
    for reason in matrix.disabled.values():
        counts[reason] = counts.get(reason, 0) + 1
    print(f"collision-matrix: {len(matrix.links)} links with geometry, {len(matrix.disabled)} pairs disabled "
          f"({', '.join(f'{n} {r}' for r, n in sorted(counts.items())) or 'none'}), {len(matrix.enabled())} checked; "
          f"{matrix.samples} samples", file=sys.stderr)
    return EXIT_OK


def _run_dask(args, model) -> int:
    """``--dask``: the check mapped over the Parquet partitions of INPUT (:func:`kinematics.distributed.collision_dask`)."""
    from .. import distributed
    from ..io.parquet import is_parquet

    if args.input == "-" or not is_parquet(args.input):
        return fail("collision", "--dask reads a Parquet INPUT (a file, a directory or a glob)", EXIT_USAGE)
    if args.output == "-":
        return fail("collision", "--dask writes a directory of Parquet files: give -o DIRECTORY", EXIT_USAGE)
    if args.per_pair or args.distance:
        return fail("collision", "--per-pair and --distance are not available with --dask", EXIT_USAGE)
    try:
        spec = distributed.model_spec(model_id=args.model, urdf=args.urdf, dh=args.dh)
        task = distributed.CollisionTask(samples=args.samples, margin=args.margin, cache_dir=args.cache,
                                         pairs=user_pairs(args))
        n = distributed.run_parquet(args.input, args.output, spec, kind="collision", address=args.dask,
                                    time_column=args.time_column or "time", collision=task)
    except (KinematicsError, OSError) as exc:
        return fail("collision", str(exc), EXIT_USAGE)
    print(f"collision: {n} configurations checked on Dask -> {args.output}", file=sys.stderr)
    return EXIT_OK


def _rows(args, model):
    """The chunks ``(start, Q)`` of INPUT: Parquet (file, directory, glob) or a trajectory file."""
    from ..io.parquet import is_parquet

    if args.input != "-" and is_parquet(args.input):
        from ..io.parquet import ParquetJointRows

        return ParquetJointRows(args.input, model, time_column=args.time_column)
    source = sys.stdin if args.input == "-" else args.input
    return open_joint_rows(source, model, "csv" if args.input == "-" else None)


def run_collision(args) -> int:
    model = model_or_exit_code(args, "collision")
    if isinstance(model, int):
        return model
    if args.dask:
        return _run_dask(args, model)
    try:
        matrix = _matrix_with_bar(model, args)
        checked = matrix.enabled()
        out = sys.stdout if args.output == "-" else open(args.output, "w", newline="", encoding="utf-8")
    except (KinematicsError, OSError) as exc:
        return fail("collision", str(exc), EXIT_USAGE)
    n_rows = n_hit = 0
    try:
        writer = csv.writer(out)
        head = ["row", "colliding"] + ([f"{a}|{b}" for a, b in checked] if args.per_pair else ["pairs"])
        writer.writerow(head + (["min_distance", "closest"] if args.distance else []))
        for start, Q in _rows(args, model):
            a = collision(model, Q, distance=args.distance, margin=args.margin, samples=args.samples,
                          cache_dir=args.cache, collision_pairs=user_pairs(args))
            for k in range(len(Q)):
                row = [start + k, int(a.colliding[k])]
                if args.per_pair:
                    hit = set(a.pairs[k])
                    row += [int(p in hit) for p in checked]
                else:
                    row.append(";".join(f"{x}|{y}" for x, y in a.pairs[k]))
                if args.distance:
                    d = a.min_distance[k]
                    row += ["" if not np.isfinite(d) else repr(float(d)),
                            "" if a.closest[k] is None else "|".join(a.closest[k])]
                writer.writerow(row)
            n_rows += len(Q)
            n_hit += int(a.colliding.sum())
    except KinematicsError as exc:
        return fail("collision", str(exc), EXIT_USAGE)
    finally:
        if out is not sys.stdout:
            out.close()
    print(f"collision: {n_hit} of {n_rows} configurations in collision ({len(checked)} pairs checked)",
          file=sys.stderr)
    return EXIT_OK
