"""Pipeline commands: ``kinematics fk``, ``jacobian`` and ``models`` (the helpers they share with the other
commands are :mod:`kinematics.cli.common`).

``fk`` and ``jacobian`` stream a trajectory file (CSV, ``.npy`` or JSON lines; see
:mod:`kinematics.io.trajectory` for the formats) through the use cases of
:mod:`kinematics.usecases` in chunks of :data:`~kinematics.io.trajectory.CHUNK_ROWS`
configurations, so memory stays bounded whatever the length of the file.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

from .. import api
from ..usecases import Query
from ..errors import KinematicsError
from ..io.catalogue import default_catalogue
from ..io.result_files import RowSampler
from ..io.trajectory import CHUNK_ROWS
from ..model.robot import RobotModel
from ..spatial.reference import REFERENCES, Reference
from . import EXIT_OK, EXIT_USAGE, add_command
from .common import (EXIT_CODES, FORMAT_HELP, chunk_times, endpoints, fail, io_options, model_or_exit_code, open_input,
                     open_output, quietly, resolve_links, stream_option_problem, timing, verdict, verification_due)
from .progress import progress


def _log_options(p: argparse.ArgumentParser) -> None:
    """Options of ROS bag input and MCAP output."""
    p.add_argument("--topic", metavar="TOPIC", help="ROS bag input: the JointState topic (default: the first one)")
    p.add_argument("--skip-incomplete", action="store_true",
                   help="ROS bag input: skip (and count) messages missing a model joint instead of failing")
    p.add_argument("--pose-topics", action="store_true",
                   help="MCAP output: also a geometry_msgs/PoseStamped per link on /pose/<link>")
    p.add_argument("--dask", metavar="SCHEDULER|local:N",
                   help="run on Dask over the partitions of a Parquet INPUT (file, directory or glob): a scheduler "
                   "address (tcp://host:8786) or local:N worker processes; OUTPUT is a directory of Parquet files")


def register(sub) -> None:
    fk = add_command(
        sub, "fk", run_fk,
        help="forward kinematics of every configuration of a trajectory file",
        description="Pose of links (T_world_link) for every configuration of INPUT, streamed in chunks. "
        "CSV output has, per link, the position <link>.x,<link>.y,<link>.z (metres, world frame) and the "
        "orientation quaternion <link>.qw,<link>.qx,<link>.qy,<link>.qz (qw >= 0); .npy output is "
        "(N, links, 4, 4); JSON lines output is {\"poses\": {link: {matrix, position, quaternion, rpy}}} per row.",
        epilog=FORMAT_HELP + "\n\nexamples:\n"
        "  kinematics fk --model ur5 trajectory.csv -o poses.csv\n"
        "  kinematics fk --model ur5 --links all q.npy -o T.npy --verify=1000\n"
        "  kinematics fk --urdf robot.urdf --links tool0,base_link q.jsonl > poses.csv\n\n" + EXIT_CODES,
    )
    fk.add_argument("--links", action="append", metavar="all|NAME[,NAME...]",
                    help="links to output: 'all', or names (comma-separated or repeated); default: the leaf links")
    io_options(fk)
    _log_options(fk)

    jac = add_command(
        sub, "jacobian", run_jacobian,
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
    )
    jac.add_argument("--link", metavar="NAME", help="the link (default: the model's first leaf link)")
    jac.add_argument("--reference", choices=REFERENCES, default=Reference.WORLD.value, help="reference frame (default world)")
    io_options(jac)
    _log_options(jac)

    models = add_command(
        sub, "models", run_models, model=False,
        help="list the bundled catalogue",
        description="List the catalogue: example-robot-data URDFs and the DH presets shipped with the library.",
    )
    models.add_argument("ids", nargs="*", metavar="ID", help="only these models")
    models.add_argument("--dof", action="store_true", help="also load each model and show its dof, links and leaves (slower)")
    models.add_argument("--json", action="store_true", help="JSON output (one array)")


def _stream(args, command: str, compute, labels, kind: str, model: RobotModel, verify) -> int:
    """Read INPUT in chunks, ``compute(Q)`` each, write OUTPUT; optionally verify a sample."""
    return quietly(_stream_unguarded, args, command, compute, labels, kind, model, verify)


def _stream_unguarded(args, command, compute, labels, kind, model, verify) -> int:
    problem = stream_option_problem(args)
    if problem:
        return fail(command, problem, EXIT_USAGE)
    source, in_fmt, dest, out_fmt = endpoints(args)
    sampler = RowSampler(args.verify or 0, args.seed)
    outside = 0
    t0 = time.perf_counter()
    with open_input(args, model, source, in_fmt) as rows:
        bar = progress(total=rows.total, desc=command, unit="row", unit_scale=True)
        try:
            with open_output(args, dest, out_fmt, kind, labels, model, rows) as writer:
                for start, Q in rows:
                    answer = compute(Q)
                    result = answer.poses if kind == "fk" else answer.jacobians
                    writer.write(result, chunk_times(rows, start, Q.shape[0]))
                    sampler.offer(start, Q, result)
                    outside += answer.out_of_limits_count()
                    bar.update(Q.shape[0])
        finally:
            bar.close()
    n = writer.rows
    timing(command, n, "configurations", args, time.perf_counter() - t0)
    if getattr(rows, "skipped", 0):
        print(f"{command}: skipped {rows.skipped} messages missing a model joint (--skip-incomplete)", file=sys.stderr)
    return verify(sampler) if verification_due(command, args, sampler, outside, n) else EXIT_OK


# ============================================================================ commands
def _run_dask(args, command: str, model: RobotModel, **what) -> int:
    """``--dask``: the computation mapped over the Parquet partitions of INPUT on a Dask cluster."""
    from .. import distributed
    from ..io.parquet import is_parquet

    if args.input == "-" or not is_parquet(args.input):
        return fail(command, "--dask reads a Parquet INPUT (a file, a directory or a glob)", EXIT_USAGE)
    if args.output == "-":
        return fail(command, "--dask writes a directory of Parquet files: give -o DIRECTORY", EXIT_USAGE)
    if args.verify is not None:
        return fail(command, "--verify is not available with --dask (verify a local run of a sample)", EXIT_USAGE)
    spec = distributed.model_spec(model_id=args.model, urdf=args.urdf, dh=args.dh)
    t0 = time.perf_counter()
    n = distributed.run_parquet(args.input, args.output, spec, kind=command, address=args.dask,
                                time_column=args.time_column or "time", **what)
    timing(command, n, "configurations", args, time.perf_counter() - t0)
    return EXIT_OK


def run_fk(args) -> int:
    model = model_or_exit_code(args, "fk")
    if isinstance(model, int):
        return model
    links = resolve_links(model, args.links)
    if args.dask:
        return _run_dask(args, "fk", model, links=links)
    if _output_format(args) == "mcap":
        if args.links and links != list(model.links):
            return fail("fk", "MCAP output is the TF tree of every link: drop --links (or give --links all)", EXIT_USAGE)
        links = list(model.links)

    query = Query(model, links=links)

    def compute(Q):
        return api.fk(query, Q)

    def verify(sampler) -> int:
        from ..verify import pinocchio

        dev = pinocchio.compare_fk(model, sampler.Q, links, poses=sampler.results)
        worst = max(dev.max_position_error, dev.max_rotation_error)
        print(f"fk: verify: {len(sampler.rows)} sampled configurations x {len(links)} links vs "
              f"{pinocchio.REFERENCE_NAME}: max position error {dev.max_position_error:.3g} m, "
              f"max rotation error {dev.max_rotation_error:.3g}", file=sys.stderr)
        return verdict("fk", worst)

    return _stream(args, "fk", compute, links, "fk", model, verify)


def run_jacobian(args) -> int:
    model = model_or_exit_code(args, "jacobian")
    if isinstance(model, int):
        return model
    link = args.link or model.leaf_links[0]
    api.resolve_links(model, [link])  # unknown link: UnknownLinkError (exit 2) before reading anything
    if args.dask:
        return _run_dask(args, "jacobian", model, link=link, reference=args.reference)

    query = Query(model, link=link)

    def compute(Q):
        return api.jacobian(query, Q, reference=args.reference)

    def verify(sampler) -> int:
        from ..verify import pinocchio

        err = pinocchio.compare_jacobian(model, sampler.Q, link, references=(args.reference,),
                                          jacobians={args.reference: sampler.results})
        print(f"jacobian: verify: {len(sampler.rows)} sampled configurations, link {link!r}, reference "
              f"{args.reference} vs {pinocchio.REFERENCE_NAME}: max entry error {err:.3g}", file=sys.stderr)
        return verdict("jacobian", err)

    return _stream(args, "jacobian", compute, model.joint_names, "jacobian", model, verify)


def _output_format(args) -> str | None:
    if args.output_format is not None:
        return args.output_format
    return "mcap" if str(args.output).lower().endswith(".mcap") else None


def run_models(args) -> int:
    cat = default_catalogue()
    ids = args.ids or cat.ids()
    try:
        entries = [cat.entry(i) for i in ids]
    except KinematicsError as exc:
        return fail("models", str(exc), EXIT_USAGE)
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
