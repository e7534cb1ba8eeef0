"""``kinematics collision`` and ``kinematics collision-matrix``: self-collision of configurations
from a file, and the allowed-collision matrix as SRDF or JSON.

``collision`` reads joint values (CSV, ``.npy`` or JSON lines, as ``kinematics fk`` does) and
writes a CSV row per configuration: ``row, colliding`` (0/1), ``pairs`` (the link pairs in
collision, ``a|b`` separated by ``;``), with ``--distance`` also ``min_distance, closest``; with
``--per-pair`` a 0/1 column per checked pair instead of ``pairs``. ``collision-matrix`` computes
(or reads back from ``--cache``) the matrix with a progress bar and writes SRDF
(``disable_collisions``; ``-o x.srdf``) or JSON (``-o x.json``).
"""

from __future__ import annotations

import csv
import json
import os
import sys

import numpy as np

from ..algorithms.collision_matrix import DEFAULT_SAMPLES
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
               "  kinematics collision --model ur5 q.npy --distance --margin 0.01 -o report.csv\n")
    p.add_argument("input", metavar="INPUT", help="joint values: .csv, .npy or .jsonl ('-': CSV on stdin)")
    p.add_argument("-o", "--output", default="-", metavar="CSV", help="the report (default: stdout)")
    p.add_argument("--distance", action="store_true", help="also the minimum distance and the closest pair")
    p.add_argument("--margin", type=float, default=0.0, metavar="M", help="closer than M metres counts as colliding")
    p.add_argument("--per-pair", action="store_true", help="a 0/1 column per checked pair instead of 'pairs'")
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


def add_filter_options(p, flag: str, help: str) -> None:
    """``flag`` (collision-free answers only) with the matrix behind it: ``--collision-samples N``,
    ``--collision-cache DIR`` (``kinematics ik``, ``ik-path``, ``workspace``)."""
    p.add_argument(flag, action="store_true", help=help + "; a model without collision geometry is refused")
    p.add_argument("--collision-samples", type=int, default=DEFAULT_SAMPLES, metavar="N",
                   help=f"random configurations behind the allowed-collision matrix (default {DEFAULT_SAMPLES})")
    p.add_argument("--collision-cache", metavar="DIR", default=os.environ.get("KIN_COLLISION_CACHE"),
                   help="keep the matrix in DIR and read it back next time (default $KIN_COLLISION_CACHE)")


def filter_options(args) -> dict:
    """The use cases' keywords of :func:`add_filter_options`' options (without the flag)."""
    return {"collision_samples": args.collision_samples, "cache_dir": args.collision_cache}


def _matrix_with_bar(model, args):
    bar = progress(total=args.samples, desc="collision matrix", unit="cfg")
    done = [0]

    def tick(k: int) -> None:
        bar.update(k - done[0])
        done[0] = k

    try:
        return collision_matrix(model, args.samples, cache_dir=args.cache, progress=tick)
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
    counts = {}
    for reason in matrix.disabled.values():
        counts[reason] = counts.get(reason, 0) + 1
    print(f"collision-matrix: {len(matrix.links)} links with geometry, {len(matrix.disabled)} pairs disabled "
          f"({', '.join(f'{n} {r}' for r, n in sorted(counts.items())) or 'none'}), {len(matrix.enabled())} checked; "
          f"{matrix.samples} samples", file=sys.stderr)
    return EXIT_OK


def run_collision(args) -> int:
    model = model_or_exit_code(args, "collision")
    if isinstance(model, int):
        return model
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
        source = sys.stdin if args.input == "-" else args.input
        for start, Q in open_joint_rows(source, model, "csv" if args.input == "-" else None):
            a = collision(model, Q, distance=args.distance, margin=args.margin, samples=args.samples,
                           cache_dir=args.cache)
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
