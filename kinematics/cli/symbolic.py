"""``kinematics symbolic``, ``kinematics poe2urdf`` and ``kinematics axes2urdf``.

``symbolic`` prints the closed forms (``A_i``, ``T``, Jacobians, task vectors) of a catalogue
model, a URDF file, or a DH table / PoE / axes description file (``.yaml``/``.json``; a DH
table's entries may be parameter names such as ``a1``), as LaTeX, text, Python or C.
``poe2urdf`` and ``axes2urdf`` write the URDF a PoE or zero-configuration axes description
becomes. Errors print one line on stderr and exit with code 2.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from .. import api
from ..errors import KinematicsError
from ..io import serial
from ..io.catalogue import default_catalogue
from ..io.dh_table import load_table, table_to_dict
from ..io.urdf import load_urdf
from . import EXIT_OK, EXIT_USAGE, add_command

KINDS = ("auto", "urdf", "dh", "poe", "axes")
REPRESENTATIONS = ("rpy", "zyx", "zyz", "position", "scara", "planar")


def register(sub) -> None:
    p = add_command(
        sub, "symbolic", run_symbolic, model=False,
        help="closed forms (A_i, T, Jacobians, task vectors) as LaTeX, text, Python or C",
        description="Derive the closed forms of a chain with sympy: the factors A_i, T(q), the Jacobians "
        "(local_world_aligned and world, linear rows first) and task vectors r(q), J_r = dr/dq. MODEL is a "
        "catalogue id, a URDF file, or a .yaml/.json DH table (entries may be parameter names such as a1), "
        "PoE description (M and screws S_i or B_i) or zero-configuration axes description (h_i, p).",
    )
    p.add_argument("model", metavar="MODEL", help="catalogue id, URDF file, or DH / PoE / axes file")
    p.add_argument("--kind", choices=KINDS, default="auto",
                   help="what MODEL is (default: catalogue id, .urdf, or from the file's fields)")
    p.add_argument("--tip", metavar="LINK", help="last link of the chain (required for trees)")
    p.add_argument("--what", default="transforms", metavar="LIST",
                   help="comma-separated: transforms, jacobian, task (default transforms)")
    p.add_argument("--format", choices=("latex", "python", "c", "text"), default="latex", help="default latex")
    p.add_argument("--no-simplify", action="store_true", help="the expanded forms only (fastest)")
    p.add_argument("--representation", choices=REPRESENTATIONS, default=None,
                   help="task vector: rpy (default), zyx, zyz, position, scara (px, py, pz, alpha_z), planar")
    p.add_argument("--components", metavar="LIST", help="comma-separated components of the task vector to keep")
    p.add_argument("--variables", choices=("q", "names"), default="q", help="q1..qn (default) or the joint names")
    p.add_argument("--prefix", default="", help="prefix of the C function names")
    p.add_argument("--timeout", type=float, default=api.DEFAULT_SYMBOLIC_TIMEOUT, metavar="SECONDS",
                   help=f"time limit (default {api.DEFAULT_SYMBOLIC_TIMEOUT:g})")
    p.add_argument("--json", action="store_true", help="print the whole answer as JSON (the service's shape)")
    p.add_argument("-o", "--output", metavar="FILE", help="write here (default: standard output)")

    for kind, label in (("poe", "a product-of-exponentials description (M, screws S_i or B_i)"),
                        ("axes", "a zero-configuration axes description (h_i, p_{i-1,i}, p_nT)")):
        q = add_command(sub, f"{kind}2urdf", run_to_urdf, model=False, kind=kind, help=f"build a URDF from {label}",
                        description=f"Read {label} (.yaml/.yml/.json, the fields of POST /models/{kind}) "
                        "and write its URDF (links base, link_1 .. link_n, tool).")
        q.add_argument("description", metavar="FILE", help="description file (.yaml, .yml or .json)")
        q.add_argument("-o", "--output", metavar="FILE", help="write the URDF here (default: standard output)")


def _error(command: str, message: str) -> int:
    print(f"kinematics {command}: error: {message}", file=sys.stderr)
    return EXIT_USAGE


def _write(command: str, text: str, output: str | None, note: str) -> int:
    if output:
        try:
            Path(output).write_text(text, encoding="utf-8")
        except OSError as exc:
            return _error(command, f"cannot write {output}: {exc.strerror or exc}")
        print(f"wrote {output}: {note}", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return EXIT_OK


def _file_kind(data: dict) -> str:
    """dh, poe or axes from a description's fields."""
    if "M" in data:
        return "poe"
    joints = data.get("joints")
    if isinstance(joints, list) and joints and isinstance(joints[0], dict) and "h" in joints[0]:
        return "axes"
    return "dh"


def _answer(args, options: dict) -> api.SymbolicAnswer:
    spec, kind = args.model, args.kind
    path = Path(spec)
    catalogue = default_catalogue()
    if kind == "auto":
        if not path.is_file() and spec in catalogue:
            kind = "catalogue"
        elif path.suffix.lower() == ".urdf":
            kind = "urdf"
        elif path.suffix.lower() in (".yaml", ".yml", ".json"):
            kind = "file"
        else:
            raise KinematicsError(f"{spec!r} is neither a catalogue id, a URDF file nor a .yaml/.json description")
    if kind == "catalogue":
        entry = catalogue.entry(spec)
        table = table_to_dict(load_table(entry.path)) if entry.source == "preset" else None
        return api.symbolic(catalogue.get(spec), tip=args.tip, dh_table=table, **options)
    if kind == "urdf":
        try:
            model = load_urdf(path)
        except OSError as exc:
            raise KinematicsError(f"cannot read {spec}: {exc.strerror or exc}") from None
        return api.symbolic(model, tip=args.tip, **options)
    data = serial.load_mapping(path, KinematicsError, "model description")
    if kind == "file":
        kind = _file_kind(data)
    if kind == "dh":
        if args.tip not in (None, "tool"):
            raise KinematicsError("--tip: a DH table's chain ends at its tool")
        return api.symbolic_dh(data, **options)
    model, _ = api.model_from_description(kind, data)
    return api.symbolic(model, tip=args.tip, **options)


def _listing(out: dict) -> str:
    """A readable page of a latex / text answer: each matrix under its name."""
    lines = ["joint variables: " + ", ".join(f"{v['symbol']} = {v['joint']}" for v in out["joint_variables"])]
    if out["parameters"]:
        lines.append("parameters: " + ", ".join(out["parameters"]))
    if out.get("components"):
        lines.append(f"task vector ({out['representation']}): " + ", ".join(out["components"]))

    def show(label, value):
        lines.append("")
        lines.append(f"{label} =")
        if isinstance(value, str):
            lines.append(value)
        else:
            lines.extend("  [" + ", ".join(row) + "]" for row in value)

    for i, A in enumerate(out.get("A", []), start=1):
        show(f"A_{i}", A)
    if "T" in out:
        show(f"T (world -> {out['tip']})", out["T"])
    for ref, J in out.get("jacobian", {}).items():
        show(f"J ({ref})", J)
    if "r" in out:
        show("r", out["r"])
        show("J_r", out["J_r"])
    return "\n".join(lines) + "\n"


def run_symbolic(args) -> int:
    what = [w.strip() for w in args.what.split(",") if w.strip()]
    components = [c.strip() for c in args.components.split(",")] if args.components else None
    options = dict(what=what, fmt=args.format, simplify=not args.no_simplify, representation=args.representation,
                   components=components, variables=args.variables, prefix=args.prefix, timeout=args.timeout)
    try:
        answer = _answer(args, options)
    except KinematicsError as exc:
        return _error("symbolic", str(exc))
    out = answer.output
    if args.json:
        text = json.dumps(out, indent=2) + "\n"
    elif args.format in ("python", "c"):
        text = out["code"]
    else:
        text = _listing(out)
    return _write("symbolic", text, args.output, f"{args.format}, {len(out['joint_variables'])} joint variables, "
                  f"{answer.seconds:.2f} s")


def run_to_urdf(args) -> int:
    command = f"{args.kind}2urdf"
    try:
        model, _ = api.model_from_description(args.kind, Path(args.description))
    except KinematicsError as exc:
        return _error(command, str(exc))
    return _write(command, model.urdf, args.output, f"{model.dof} joints")
