"""``kinematics`` command line: one sub-command module per feature.

Each module in this package exposes ``register(subparsers)`` which adds its commands and
sets ``func`` on them; ``func(args)`` returns the process exit code. Other installed
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
                   "collision")
#: entry-point group of commands that other packages add
PLUGIN_GROUP = "kinematics.commands"

EXIT_OK, EXIT_DISAGREE, EXIT_USAGE, EXIT_MODEL = 0, 1, 2, 3


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="kinematics",
        description="Forward kinematics and Jacobians of robots (URDF, DH), checked against Pinocchio.",
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
