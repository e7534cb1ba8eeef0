"""The layer contracts of ``pyproject.toml`` ([tool.importlinter]) hold, and they can fail.

``lint-imports`` builds the import graph of ``kinematics`` and ``app`` (function-level
imports included) and checks: the library's layers import only downwards, the library has
no web imports, only ``kinematics.verify`` imports Pinocchio, the service reaches the
computing layers only through ``kinematics.api``, only ``kinematics.algorithms.symbolic`` imports
sympy, and no package has an import cycle.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.paths import REPO

LINT_IMPORTS = Path(sys.executable).with_name("lint-imports")


def _lint(root: Path) -> subprocess.CompletedProcess:
    return subprocess.run([str(LINT_IMPORTS), "--no-cache"], cwd=root, capture_output=True, text=True, timeout=120,
                          env={"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin"})


def test_import_contracts_are_kept():
    r = _lint(REPO)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "0 broken" in r.stdout and "9 kept" in r.stdout, r.stdout


@pytest.mark.parametrize("module, line, contract", [
    ("kinematics/spatial/rotations.py", "from kinematics.engine import poe", "layered"),  # an upward import
    ("kinematics/engine/plans.py", "    from ..io import urdf", "layered"),  # io and engine are independent
    ("kinematics/model/robot.py", "    import fastapi", "web stack"),  # a function-level web import
    ("kinematics/algorithms/fk.py", "import pinocchio", "Pinocchio"),
    ("kinematics/algorithms/task.py", "    import sympy", "sympy"),  # only algorithms.symbolic may
    ("app/routes/symbolic.py", "import sympy", "sympy"),
    ("app/views.py", "from kinematics.engine.poe import compile_model", "kinematics.api"),
    ("kinematics/io/urdf.py", "    import mujoco", "MuJoCo"),  # only io.mjcf may
    ("kinematics/io/xacro.py", "    import xacro", "MuJoCo"),  # xacro runs only in the sandboxed worker
    ("kinematics/algorithms/ik.py", "    import scipy", "scipy"),  # only the calibration package may
    ("kinematics/io/urdf.py", "from . import catalogue", "cycles"),  # catalogue imports urdf
    ("kinematics/client.py", "    from kinematics import api", "Python client"),  # the client speaks HTTP only
    ("kinematics/usecases/fk.py", "    from .. import distributed", "layered"),  # distributed sits above the use cases
    ("kinematics/usecases/fk.py", "    from .. import api", "layered"),  # the facade sits above the use cases
])
def test_a_violation_breaks_its_contract(tmp_path, module, line, contract):
    """Each contract catches the violation it is there for (on a copy of the sources)."""
    for name in ("kinematics", "app"):
        shutil.copytree(REPO / name, tmp_path / name, ignore=shutil.ignore_patterns("__pycache__", "static"))
    shutil.copy(REPO / "pyproject.toml", tmp_path / "pyproject.toml")
    target = tmp_path / module
    lines = target.read_text().splitlines()
    at = next(i for i, text in enumerate(lines) if text.startswith("def ")) + 1 if line.startswith(" ") else \
        next(i for i, text in enumerate(lines) if text.startswith(("import ", "from "))) + 1
    lines.insert(at, line)
    target.write_text("\n".join(lines) + "\n")
    r = _lint(tmp_path)
    assert r.returncode != 0, r.stdout
    broken = [text for text in r.stdout.splitlines() if text.endswith("BROKEN") or "BROKEN (" in text]
    assert any(contract in text for text in broken), r.stdout


def test_routes_share_code_through_the_adapter_not_each_other():
    """A route module imports no private name (``_x``) of another route module: what routes share
    lives in ``app/adapter.py``."""
    import ast

    offenders = []
    for path in sorted((REPO / "app" / "routes").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.level == 1 and node.module:
                offenders += [f"{path.name}: from .{node.module} import {a.name}" for a in node.names
                              if a.name.startswith("_")]
    assert not offenders, offenders

