"""Pipeline commands: ``kinematics fk``, ``jacobian`` and ``models``.

``fk`` and ``jacobian`` stream a trajectory file (CSV, ``.npy`` or JSON lines; see
:mod:`kinematics.io.trajectory` for the formats) through the use cases of
:mod:`kinematics.api` in chunks of :data:`~kinematics.io.trajectory.CHUNK_ROWS`
configurations, so memory stays bounded whatever the length of the file.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time


from .. import api
from ..errors import KinematicsError
from ..io.catalogue import default_catalogue
from ..io.trajectory import CHUNK_ROWS, FORMATS, ResultWriter, RowSampler, TrajectoryFileError, format_of, open_joint_rows
from ..model.robot import RobotModel
from ..spatial.reference import REFERENCES, Reference
from ..tolerances import AGREEMENT_TOLERANCE
from . import EXIT_DISAGREE, EXIT_MODEL, EXIT_OK, EXIT_USAGE
from .progress import progress
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
  Error messages count CSV/JSON lines from 1 (as an editor does) and .npy rows from 0."""


class ModelLoadError(Exception):
    """The model named on the command line cannot be loaded (exit code 3)."""


# ============================================================================ registration
def _model_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("model (one of)")
    src = g.add_mutually_exclusive_group(required=True)
    src.add_argument("--model", metavar="ID", help="a catalogue model (see `kinematics models`)")
    src.add_argument("--urdf", metavar="FILE", help="a URDF file (meshes it names are never opened)")
    src.add_argument("--dh", metavar="TABLE", help="a DH table (.yaml/.yml/.json), converted to URDF")


def _io_options(p: argparse.ArgumentParser, what: str = "joint values", verify: bool = True) -> None:
    """INPUT (``what`` it holds), -o OUTPUT, formats, --chunk and (``verify``) --verify K / --seed."""
    p.add_argument("input", metavar="INPUT", help=f"{what}: .csv, .npy or .jsonl ('-': CSV on stdin)")
    p.add_argument("-o", "--output", metavar="OUTPUT", default="-",
                   help="results file: .csv, .npy or .jsonl by extension (default: CSV on stdout)")
    p.add_argument("--input-format", choices=FORMATS, help="format of INPUT when its extension does not tell")
    p.add_argument("--output-format", choices=FORMATS, help="format of OUTPUT when its extension does not tell")
    if verify:
        p.add_argument("--verify", nargs="?", type=int, const=DEFAULT_VERIFY_ROWS, default=None, metavar="K",
                       help=f"compare K randomly sampled rows (default {DEFAULT_VERIFY_ROWS}) with Pinocchio; "
                       f"print the largest deviations to stderr; exit 1 above {AGREEMENT_TOLERANCE:g} "
                       "(write --verify=K, or put --verify after INPUT)")
        p.add_argument("--seed", type=int, default=0, help="seed of the --verify sample (default 0)")
    p.add_argument("--chunk", type=int, default=CHUNK_ROWS, metavar="ROWS",
                   help=f"rows per chunk (default {CHUNK_ROWS}); bounds the memory used")


def register(sub) -> None:
    fk = sub.add_parser(
        "fk",
        help="forward kinematics of every configuration of a trajectory file",
        description="Pose of links (T_world_link) for every configuration of INPUT, streamed in chunks. "
        "CSV output has, per link, the position <link>.x,<link>.y,<link>.z (metres, world frame) and the "
        "orientation quaternion <link>.qw,<link>.qx,<link>.qy,<link>.qz (qw >= 0); .npy output is "
        "(N, links, 4, 4); JSON lines output is {\"poses\": {link: {matrix, position, quaternion, rpy}}} per row.",
        epilog=FORMAT_HELP + "\n\nexamples:\n"
        "  kinematics fk --model ur5 trajectory.csv -o poses.csv\n"
        "  kinematics fk --model ur5 --links all q.npy -o T.npy --verify=1000\n"
        "  kinematics fk --urdf robot.urdf --links tool0,base_link q.jsonl > poses.csv\n\n" + EXIT_CODES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _model_options(fk)
    fk.add_argument("--links", action="append", metavar="all|NAME[,NAME...]",
                    help="links to output: 'all', or names (comma-separated or repeated); default: the leaf links")
    _io_options(fk)
    fk.set_defaults(func=run_fk)

    jac = sub.add_parser(
        "jacobian",
        help="Jacobian of a link for every configuration of a trajectory file",
        description="Jacobian (6 x dof, linear rows first, columns in joint_names order) of one link for every "
        "configuration of INPUT, streamed in chunks. CSV output has 6*dof columns J<r><c>, row-major: r in 0..5 "
        "(0-2 linear x,y,z; 3-5 angular x,y,z), c the 0-based joint index; .npy output is (N, 6, dof); "
        "JSON lines output is {\"jacobian\": [[...] x 6]} per row.",
        epilog=FORMAT_HELP + "\n\nreferences (Pinocchio's meaning):\n"
        "  world                twist of the body at the world origin, world axes\n"
        "  local                twist in the link's own frame\n"
        "  local_world_aligned  velocity of the link origin and angular velocity, world axes\n\n"
        "example:\n  kinematics jacobian --model panda --link panda_link8 --reference local q.csv -o J.npy\n\n"
        + EXIT_CODES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _model_options(jac)
    jac.add_argument("--link", metavar="NAME", help="the link (default: the model's first leaf link)")
    jac.add_argument("--reference", choices=REFERENCES, default=Reference.WORLD.value, help="reference frame (default world)")
    _io_options(jac)
    jac.set_defaults(func=run_jacobian)

    models = sub.add_parser(
        "models",
        help="list the bundled catalogue",
        description="List the catalogue: example-robot-data URDFs and the DH presets shipped with the library.",
    )
    models.add_argument("ids", nargs="*", metavar="ID", help="only these models")
    models.add_argument("--dof", action="store_true", help="also load each model and show its dof, links and leaves (slower)")
    models.add_argument("--json", action="store_true", help="JSON output (one array)")
    models.set_defaults(func=run_models)


# ============================================================================ helpers
def load_model(args) -> RobotModel:
    """The model named by ``--model``, ``--urdf`` or ``--dh`` (raises :class:`ModelLoadError`)."""
    try:
        return api.load_model(model_id=args.model, urdf=args.urdf, dh=args.dh)
    except OSError as exc:
        path = exc.filename or args.urdf or args.dh
        raise ModelLoadError(f"cannot read {path}: {exc.strerror or exc}") from None
    except KinematicsError as exc:
        raise ModelLoadError(str(exc)) from None


def _resolve_links(model: RobotModel, spec: list[str] | None) -> list[str]:
    if not spec:
        return api.resolve_links(model, None)
    names = [n.strip() for s in spec for n in s.split(",") if n.strip()]
    if names == ["all"]:
        return api.resolve_links(model, "all")
    if "all" in names:
        raise TrajectoryFileError("--links all cannot be combined with link names")
    api.resolve_links(model, names)  # raises UnknownLinkError naming the link
    return names


def _fail(command: str, message: str, code: int) -> int:
    print(f"kinematics {command}: error: {message}", file=sys.stderr)
    return code


def _stream(args, command: str, compute, labels, kind: str, model: RobotModel, verify) -> int:
    """Read INPUT in chunks, ``compute(Q)`` each, write OUTPUT; optionally verify a sample."""
    return _quietly(_stream_unguarded, args, command, compute, labels, kind, model, verify)


def _quietly(run, *args) -> int:
    """``run(*args)``, stopping quietly when the reader of stdout goes away (e.g. `| head`)."""
    try:
        return run(*args)
    except BrokenPipeError:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return EXIT_OK


def _endpoints(args) -> tuple:
    """``(source, input format, destination, output format)`` of INPUT and -o OUTPUT ('-': stdin, stdout)."""
    in_fmt = "csv" if args.input == "-" and args.input_format is None else args.input_format
    out_fmt = "csv" if args.output == "-" and args.output_format is None else args.output_format
    out_fmt = format_of(args.output, out_fmt)
    source = sys.stdin if args.input == "-" else args.input
    dest = sys.stdout if args.output == "-" else args.output
    return source, in_fmt, dest, out_fmt


def _timing(command: str, n: int, noun: str, args, elapsed: float) -> None:
    """On a terminal, how many rows went where, and how fast."""
    if sys.stderr.isatty():
        where = "stdout" if args.output == "-" else args.output
        print(f"{command}: {n} {noun} -> {where} in {elapsed:.2f} s ({n / max(elapsed, 1e-9):,.0f}/s)", file=sys.stderr)


def _stream_unguarded(args, command, compute, labels, kind, model, verify) -> int:
    if args.chunk < 1:
        return _fail(command, "--chunk must be positive", EXIT_USAGE)
    if args.verify is not None and args.verify < 1:
        return _fail(command, "--verify needs a positive number of rows", EXIT_USAGE)
    source, in_fmt, dest, out_fmt = _endpoints(args)
    sampler = RowSampler(args.verify or 0, args.seed)
    outside = 0
    t0 = time.perf_counter()
    with open_joint_rows(source, model, in_fmt, args.chunk) as rows:
        bar = progress(total=rows.total, desc=command, unit="row", unit_scale=True)
        try:
            with ResultWriter(dest, out_fmt, kind, labels) as writer:
                for start, Q in rows:
                    answer = compute(Q)
                    result = answer.poses if kind == "fk" else answer.jacobians
                    writer.write(result)
                    sampler.offer(start, Q, result)
                    outside += answer.out_of_limits_count()
                    bar.update(Q.shape[0])
        finally:
            bar.close()
    n = writer.rows
    _timing(command, n, "configurations", args, time.perf_counter() - t0)
    if outside:
        print(f"{command}: note: {outside} of {n} configurations have joint values outside the joint limits "
              "(computed anyway)", file=sys.stderr)
    if args.verify is None:
        return EXIT_OK
    if sampler.Q is None:
        print(f"{command}: verify: no configuration to check", file=sys.stderr)
        return EXIT_OK
    return verify(sampler)


# ============================================================================ commands
def run_fk(args) -> int:
    try:
        model = load_model(args)
    except ModelLoadError as exc:
        return _fail("fk", str(exc), EXIT_MODEL)
    links = _resolve_links(model, args.links)

    def compute(Q):
        return api.fk(model, Q, links=links)

    def verify(sampler) -> int:
        from ..verify import pinocchio

        dev = pinocchio.compare_fk(model, sampler.Q, links, poses=sampler.results)
        worst = max(dev.max_position_error, dev.max_rotation_error)
        print(f"fk: verify: {len(sampler.rows)} sampled configurations x {len(links)} links vs "
              f"{pinocchio.REFERENCE_NAME}: max position error {dev.max_position_error:.3g} m, "
              f"max rotation error {dev.max_rotation_error:.3g}", file=sys.stderr)
        return _verdict("fk", worst)

    return _stream(args, "fk", compute, links, "fk", model, verify)


def run_jacobian(args) -> int:
    try:
        model = load_model(args)
    except ModelLoadError as exc:
        return _fail("jacobian", str(exc), EXIT_MODEL)
    link = args.link or model.leaf_links[0]
    api.resolve_links(model, [link])  # unknown link: UnknownLinkError (exit 2) before reading anything

    def compute(Q):
        return api.jacobian(model, Q, link=link, reference=args.reference)

    def verify(sampler) -> int:
        from ..verify import pinocchio

        err = pinocchio.compare_jacobian(model, sampler.Q, link, references=(args.reference,),
                                          jacobians={args.reference: sampler.results})
        print(f"jacobian: verify: {len(sampler.rows)} sampled configurations, link {link!r}, reference "
              f"{args.reference} vs {pinocchio.REFERENCE_NAME}: max entry error {err:.3g}", file=sys.stderr)
        return _verdict("jacobian", err)

    return _stream(args, "jacobian", compute, model.joint_names, "jacobian", model, verify)


def _verdict(command: str, worst: float) -> int:
    if worst > AGREEMENT_TOLERANCE:
        print(f"{command}: verify: FAIL: deviation {worst:.3g} exceeds {AGREEMENT_TOLERANCE:g}", file=sys.stderr)
        return EXIT_DISAGREE
    return EXIT_OK


def run_models(args) -> int:
    cat = default_catalogue()
    ids = args.ids or cat.ids()
    try:
        entries = [cat.entry(i) for i in ids]
    except KinematicsError as exc:
        return _fail("models", str(exc), EXIT_USAGE)
    records = []
    for e in (progress(entries, desc="models", unit="model") if args.dof else entries):
        rec = {"id": e.id, "name": e.name, "source": e.source}
        if args.dof:
            try:
                m = cat.get(e.id)
                rec.update(dof=m.dof, links=len(m.links), leaf_links=list(m.leaf_links))
            except KinematicsError as exc:
                rec.update(dof=None, error=str(exc))
        records.append(rec)
    if args.json:
        json.dump(records, sys.stdout, indent=1)
        sys.stdout.write("\n")
        return EXIT_OK
    w = max([len(r["id"]) for r in records] + [2])
    head = f"{'id':<{w}}  {'source':<18}"
    print(head + ("  dof  links  leaf links" if args.dof else ""))
    for r in records:
        line = f"{r['id']:<{w}}  {r['source']:<18}"
        if args.dof:
            if r.get("error"):
                line += f"  {'-':>3}  {'-':>5}  refused: {r['error']}"
            else:
                leaves = ", ".join(r["leaf_links"])
                line += f"  {r['dof']:>3}  {r['links']:>5}  {leaves if len(leaves) <= 60 else leaves[:57] + '...'}"
        print(line)
    return EXIT_OK
