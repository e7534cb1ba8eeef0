"""``kinematics dh2urdf`` and ``kinematics urdf2dh``: DH tables to URDF and back.

Errors (bad table, unreadable file, unknown catalogue id or link, a model with no DH form)
print one line on stderr and exit with code 2.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

from ..algorithms.dh import dh_deviation, urdf_to_dh
from ..errors import KinematicsError
from ..io.catalogue import default_catalogue
from ..io.dh_table import DHTable, load_table, table_to_dict, table_to_urdf
from ..io.urdf import load_urdf
from . import EXIT_OK, EXIT_USAGE, add_command

#: configurations of ``urdf2dh --check``
CHECK_SAMPLES = 1000


def register(sub) -> None:
    p = add_command(
        sub, "dh2urdf", run_dh2urdf, model=False,
        help="build a URDF from a DH table (YAML or JSON)",
        description="Read a Denavit-Hartenberg table (.yaml/.yml/.json, the fields of POST /models/dh) "
        "and write the URDF whose link frame_i is DH frame i and whose leaf link 'tool' is the tool frame.",
    )
    p.add_argument("table", metavar="TABLE", help="table file (.yaml, .yml or .json)")
    p.add_argument("-o", "--output", metavar="FILE", help="write the URDF here (default: standard output)")

    p = add_command(
        sub, "urdf2dh", run_urdf2dh, model=False,
        help="the DH table (with base and tool) of a URDF chain",
        description="Print the standard or modified DH table of the chain from the root link to --tip "
        "(default: the only leaf link), with the base and tool transforms that make its FK equal "
        "the URDF's. The model is a URDF file or a catalogue id.",
    )
    p.add_argument("model", metavar="ROBOT.urdf|CATALOGUE_ID", help="URDF file or catalogue id (e.g. ur5)")
    p.add_argument("--tip", metavar="LINK", help="last link of the chain (required for trees)")
    p.add_argument("--convention", choices=("standard", "modified"), default="standard", help="default standard")
    p.add_argument("--degrees", action="store_true", help="angles in degrees (default radians)")
    p.add_argument("--json", action="store_true", help="print JSON (the shape dh2urdf and POST /models/dh read)")
    p.add_argument(
        "--check",
        type=int,
        nargs="?",
        const=CHECK_SAMPLES,
        metavar="N",
        help=f"also report (on stderr) the largest deviation of the table's FK from the URDF's at N random "
        f"configurations within the limits (default {CHECK_SAMPLES})",
    )


def _error(command: str, message: str) -> int:
    print(f"kinematics {command}: error: {message}", file=sys.stderr)
    return EXIT_USAGE


def run_dh2urdf(args) -> int:
    try:
        table = load_table(args.table)
        urdf = table_to_urdf(table)
    except KinematicsError as exc:
        return _error("dh2urdf", str(exc))
    if args.output:
        try:
            Path(args.output).write_text(urdf, encoding="utf-8")
        except OSError as exc:
            return _error("dh2urdf", f"cannot write {args.output}: {exc.strerror or exc}")
        print(f"wrote {args.output}: {table.dof} joints, {table.convention} DH", file=sys.stderr)
    else:
        sys.stdout.write(urdf)
    return EXIT_OK


def _load_model(spec: str):
    path = Path(spec)
    if path.is_file():
        try:
            return load_urdf(path)
        except OSError as exc:
            raise KinematicsError(f"cannot read {spec}: {exc.strerror or exc}") from None
    catalogue = default_catalogue()
    if spec in catalogue:
        return catalogue.get(spec)
    raise KinematicsError(f"{spec!r} is neither a URDF file nor a catalogue id (see GET /models)")


def run_urdf2dh(args) -> int:
    try:
        model = _load_model(args.model)
        table = urdf_to_dh(model, tip=args.tip, convention=args.convention)
    except KinematicsError as exc:
        return _error("urdf2dh", str(exc))
    angles = "degrees" if args.degrees else "radians"
    if args.check is not None:
        if args.check < 1:
            return _error("urdf2dh", f"--check: {args.check} configurations; give at least 1")
        print(check_line(model, table, args.tip, args.check), file=sys.stderr)
    if args.json:
        print(json.dumps(table_to_dict(table, angles=angles), indent=2))
    else:
        print(format_table(table, angles))
    return EXIT_OK


def check_line(model, table: DHTable, tip: str | None, samples: int, seed: int = 0) -> str:
    """One line: the largest deviation of ``base A_1..A_n tool`` from the URDF's FK of the tip."""
    tip = tip or model.leaf_links[0]
    Q = model.sample_configurations(samples, np.random.default_rng(seed), continuous_range=math.pi)
    pos, rot = dh_deviation(model, table, tip, Q)
    return (
        f"check: {table.convention} DH vs URDF FK of {tip!r} at {samples} random configurations: "
        f"max position error {pos:.3g} m, max rotation error {rot:.3g}"
    )


def _num(v: float, digits: int = 6) -> str:
    s = f"{v:.{digits}f}"
    return "0" if float(s) == 0 else s.rstrip("0").rstrip(".")


def format_table(table: DHTable, angles: str = "radians") -> str:
    """A table a person can read: aligned columns with headers, then base and tool matrices."""
    deg = angles == "degrees"
    conv = (lambda v: math.degrees(v)) if deg else (lambda v: v)
    unit = "deg" if deg else "rad"
    sub = "_{i-1}" if table.convention == "modified" else ""
    headers = ["i", "joint", "type", f"a{sub} [m]", f"alpha{sub} [{unit}]", "d [m]", f"theta [{unit}]", "limits"]
    lines = []
    for i, r in enumerate(table.rows, start=1):
        if r.limits is None:
            lim = "-"
        elif r.type == "revolute":
            lim = f"[{_num(conv(r.limits[0]), 4)}, {_num(conv(r.limits[1]), 4)}] {unit}"
        else:
            lim = f"[{_num(r.limits[0], 4)}, {_num(r.limits[1], 4)}] m"
        var = " + q" if r.type == "revolute" else ""
        dvar = " + q" if r.type == "prismatic" else ""
        lines.append(
            [str(i), r.name, r.type, _num(r.a), _num(conv(r.alpha)), _num(r.d) + dvar, _num(conv(r.theta)) + var, lim]
        )
    widths = [max(len(h), *(len(row[k]) for row in lines)) for k, h in enumerate(headers)]
    right = {0, 3, 4, 5, 6}

    def fmt(cells):
        return "  ".join(c.rjust(w) if k in right else c.ljust(w) for k, (c, w) in enumerate(zip(cells, widths))).rstrip()

    formula = (
        "A_i = Rot_z(theta_i) Trans_z(d_i) Trans_x(a_i) Rot_x(alpha_i)"
        if table.convention == "standard"
        else "A_i = Rot_x(alpha_{i-1}) Trans_x(a_{i-1}) Rot_z(theta_i) Trans_z(d_i)"
    )
    out = [
        f"robot: {table.name}   convention: {table.convention}   angles: {angles}   joints: {table.dof}",
        f"{formula};  T_world_tool(q) = base A_1 ... A_n tool",
        "",
        fmt(headers),
        fmt(["-" * w for w in widths]),
    ]
    out += [fmt(row) for row in lines]
    for label, T in (("base = T_world_frame0", table.base), (f"tool = T_frame{table.dof}_tool", table.tool)):
        out += ["", f"{label}:"]
        cells = [[_num(v) for v in row] for row in np.asarray(T)]
        w = max(len(c) for row in cells for c in row)
        out += ["  [" + "  ".join(c.rjust(w) for c in row) + "]" for row in cells]
    return "\n".join(out)
