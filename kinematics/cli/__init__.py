"""``kinematics`` command line: one sub-command module per feature.

Each module in this package exposes ``register(subparsers)`` which adds its commands with
:func:`add_command` (the parser, the model options when the command reads a model, and
``func``); ``func(args)`` returns the process exit code. Other installed
packages add commands the same way through the entry-point group ``kinematics.commands``
(the service adds ``serve``; the library itself never names it).

Exit codes: 0 success; 1 a check found a disagreement; 2 bad usage or bad input file;
3 a model could not be loaded.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from importlib.metadata import entry_points

from ..errors import KinematicsError

#: sub-command modules, in the order their commands appear in ``--help``
COMMAND_MODULES = ("check", "dh", "pipeline", "ik", "ik_path", "velocity", "workspace", "symbolic", "calibrate",
                   "collision", "warm_up", "trajectory")
#: entry-point group of commands that other packages add
PLUGIN_GROUP = "kinematics.commands"

EXIT_OK, EXIT_DISAGREE, EXIT_USAGE, EXIT_MODEL = 0, 1, 2, 3


def add_command(sub, name: str, run, *, help: str, description: str, epilog: str | None = None,
                model: bool = True, **defaults) -> argparse.ArgumentParser:
    """Add the sub-command ``name`` to ``sub`` (the parser's sub-parsers) and return its parser.

    ``run(args)`` becomes its ``func`` (``defaults`` are set beside it). An ``epilog`` (formats,
    examples, exit codes) is printed as written, and then so is the description; ``model``
    declares the model options (:func:`model_options`) before the command's own.

    >>> parser = argparse.ArgumentParser(prog="kinematics")
    >>> p = add_command(parser.add_subparsers(), "demo", len, help="h", description="d")
    >>> args = parser.parse_args(["demo", "--model", "ur5"])
    >>> args.model, args.func is len
    ('ur5', True)
    """
    formatter = argparse.RawDescriptionHelpFormatter if epilog else argparse.HelpFormatter
    p = sub.add_parser(name, help=help, description=description, epilog=epilog, formatter_class=formatter)
    if model:
        model_options(p)
    p.set_defaults(func=run, **defaults)
    return p


def model_options(p: argparse.ArgumentParser) -> None:
    """The model a command reads: one of --model, --urdf, --dh, --xacro, --mjcf (with --arg, --package-path)."""
    g = p.add_argument_group("model (one of)")
    src = g.add_mutually_exclusive_group(required=True)
    src.add_argument("--model", metavar="ID", help="a catalogue model (see `kinematics models`)")
    src.add_argument("--urdf", metavar="FILE", help="a URDF file (meshes it names are never opened)")
    src.add_argument("--dh", metavar="TABLE", help="a DH table (.yaml/.yml/.json), converted to URDF")
    src.add_argument("--xacro", metavar="FILE", help="a xacro file, expanded in a sandboxed process (it reads only "
                     "its directory and --package-path)")
    src.add_argument("--mjcf", metavar="FILE", help="a MuJoCo MJCF file (hinge, slide and fixed bodies; meshes "
                     "are never opened)")
    g.add_argument("--arg", action="append", default=[], metavar="NAME=VALUE",
                   help="a xacro argument (repeatable; with --xacro)")
    g.add_argument("--package-path", action="append", default=[], metavar="DIR",
                   help="a directory of ROS packages that $(find pkg) resolves (repeatable; with --xacro)")


#: what the program does, in its --help (each command's line follows it)
DESCRIPTION = ("Kinematics of robots (URDF, xacro, MJCF, DH tables, the catalogue), checked against Pinocchio: "
               "forward kinematics, Jacobians and velocities, inverse kinematics (one solution, every solution, "
               "Cartesian paths), self-collision, workspaces, calibration, closed forms and task vectors; batches "
               "from files (CSV, .npy, Parquet, logs); and the REST service (serve).")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="kinematics",
        description=DESCRIPTION, epilog="`kinematics COMMAND --help` gives a command's options and examples.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"{__name__}.{name}":
                continue  # feature not installed in this build
            raise
        module.register(sub)
    for ep in sorted(entry_points(group=PLUGIN_GROUP), key=lambda e: e.name):
        ep.load()(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except KinematicsError as exc:
        print(f"kinematics {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except BrokenPipeError:  # e.g. piped into `head`
        return EXIT_OK


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
