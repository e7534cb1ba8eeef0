"""What adding an option touches: per name, the function signatures that take a parameter of that name
and the files that name it, in the library and the service (``python scripts/option_reach.py [NAME ...]``,
from the repository root; ``--layers`` splits the counts by package).

    python scripts/option_reach.py position_tolerance random_seed max_iterations restarts locked avoid_collisions
"""

from __future__ import annotations

import ast
import pathlib
import sys
from collections import Counter

DEFAULT = ("position_tolerance", "random_seed", "max_iterations", "restarts", "locked", "avoid_collisions")


def reach(name: str, roots=("kinematics", "app")) -> tuple[Counter, Counter]:
    """``(signatures per package, naming files per package)`` of ``name``."""
    signatures, files = Counter(), Counter()
    for root in roots:
        for path in sorted(pathlib.Path(root).rglob("*.py")):
            text = path.read_text(encoding="utf-8")
            package = ".".join(path.parts[:2]) if path.parts[0] == "kinematics" else path.parts[0]
            if name in text:
                files[package] += 1
            for node in ast.walk(ast.parse(text)):
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    a = node.args
                    if name in [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]:
                        signatures[package] += 1
    return signatures, files


def main(argv: list[str]) -> None:
    layers = "--layers" in argv
    names = [a for a in argv if not a.startswith("--")] or DEFAULT
    for name in names:
        signatures, files = reach(name)
        line = f"{name}: {sum(signatures.values())} signatures, {sum(files.values())} files name it"
        if layers:
            line += "; signatures by package: " + ", ".join(f"{k} {v}" for k, v in sorted(signatures.items()))
        print(line)


if __name__ == "__main__":
    main(sys.argv[1:])
