"""``kinematics velocity``: the velocity of links along a trajectory of joint values and velocities.

Rows of ``q`` and ``qdot`` (CSV with joint-name and ``<joint>.qdot`` columns, ``.npy`` (N, 2 dof),
JSON lines; see :class:`kinematics.io.trajectory.StateRows`) stream in chunks through
:func:`kinematics.usecases.velocity`; per row and link the twist in one reference goes to OUTPUT.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from .. import api
from ..usecases import Query
from ..io.result_files import ResultWriter, RowSampler
from ..io.trajectory import open_state_rows
from ..spatial.reference import REFERENCES, Reference
from . import EXIT_OK, EXIT_USAGE, add_command
from .common import (endpoints, fail, io_options, model_or_exit_code, parse_point, quietly, resolve_links,
                     stream_option_problem, timing, verdict, verification_due)
from .progress import progress

STATE_HELP = """input (INPUT, by extension; '-' reads CSV from standard input): per row the joint values, then
the joint velocities (rad/s for revolute joints, m/s for prismatic ones)
  .csv     2*dof numbers per line; an optional header names the columns in any order: the joint
           names for q, '<joint>.qdot' for qdot (e.g. elbow_joint, elbow_joint.qdot)
  .npy     numeric array (N, 2*dof): [q | qdot]
  .jsonl   per line a list of 2*dof numbers, or {"q": [...] or {joint: value}, "qdot": [...] or {...}}

output (-o, by extension; CSV on stdout by default), per link the twist in --reference, linear first:
  .csv     <link>.vx,<link>.vy,<link>.vz,<link>.wx,<link>.wy,<link>.wz
  .npy     (N, links, 6)
  .jsonl   {"twists": {link: [vx, vy, vz, wx, wy, wz]}}

references (Pinocchio's getFrameVelocity):
  local_world_aligned  velocity of the link origin and angular velocity, world axes (default)
  world                the body's twist at the world origin, world axes
  local                velocity of the link origin and angular velocity, the link's axes"""


def register(sub) -> None:
    p = add_command(
        sub, "velocity", run_velocity,
        help="velocity of links for every row of joint values and velocities of a file",
        description="Twist of links for every row (q, qdot) of INPUT, streamed in chunks, computed in one pass "
        "down the tree per configuration (the same as J(q) qdot of each link's Jacobian).",
        epilog=STATE_HELP + "\n\nexamples:\n"
        "  kinematics velocity --model ur5 --links tool0 states.csv -o v.csv\n"
        "  kinematics velocity --model panda --reference world qqd.npy -o twists.npy --verify=100\n"
        "  kinematics velocity --model ur5 --links tool0 --point 0,0,0.1 states.jsonl\n",
    )
    p.add_argument("--links", action="append", metavar="all|NAME[,NAME...]",
                   help="links to output: 'all' (default), or names (comma-separated or repeated)")
    p.add_argument("--reference", choices=REFERENCES, default=Reference.LOCAL_WORLD_ALIGNED.value,
                   help="reference of the twists (default local_world_aligned)")
    p.add_argument("--point", metavar="X,Y,Z", help="the velocity of this point of each link (link frame, metres) "
                   "instead of the link origin (write --point=-0.1,0,0 when the first is negative)")
    io_options(p, what="joint values and velocities")


def run_velocity(args) -> int:
    model = model_or_exit_code(args, "velocity")
    if isinstance(model, int):
        return model
    links = resolve_links(model, args.links or ["all"])
    try:
        point = parse_point(args.point)
    except ValueError as exc:
        return fail("velocity", str(exc), EXIT_USAGE)
    return quietly(_run, args, model, links, point)


def _run(args, model, links, point) -> int:
    problem = stream_option_problem(args)
    if problem:
        return fail("velocity", problem, EXIT_USAGE)
    source, in_fmt, dest, out_fmt = endpoints(args)
    sampler = RowSampler(args.verify or 0, args.seed)
    reference = Reference(args.reference)
    outside = 0
    query = Query(model, links=links, point=point)  # the request shape, built once for every chunk
    t0 = time.perf_counter()
    with open_state_rows(source, model, in_fmt, args.chunk) as rows:
        bar = progress(total=rows.total, desc="velocity", unit="row", unit_scale=True)
        try:
            with ResultWriter(dest, out_fmt, "velocity", links) as writer:
                for start, (Q, Qd) in rows:
                    answer = api.velocity(query, Q, Qd)
                    result = answer.twists[reference]
                    writer.write(result)
                    if args.verify:
                        sampler.offer(start, np.concatenate([Q, Qd], axis=1), result)
                    outside += answer.out_of_limits_count()
                    bar.update(Q.shape[0])
        finally:
            bar.close()
    n = writer.rows
    timing("velocity", n, "configurations", args, time.perf_counter() - t0)
    if not verification_due("velocity", args, sampler, outside, n):
        return EXIT_OK
    from ..verify import pinocchio

    dof = model.dof
    err = pinocchio.compare_velocity(model, sampler.Q[:, :dof], sampler.Q[:, dof:], links, references=(reference,),
                                     twists={reference: sampler.results}, tool=query.T_tool)
    print(f"velocity: verify: {len(sampler.rows)} sampled rows x {len(links)} links, reference {reference.value} vs "
          f"{pinocchio.REFERENCE_NAME}: max twist error {err:.3g}", file=sys.stderr)
    return verdict("velocity", err)
