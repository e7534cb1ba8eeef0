"""Helpers the tests share: ``.npy`` bodies and files, the agreement bound with Pinocchio, packages
with meshes as upload archives, and a guard that fails a test which opens any file."""

from __future__ import annotations

import builtins
import io
import os
import zipfile
from pathlib import Path

import numpy as np

from kinematics.tolerances import AGREEMENT_TOLERANCE

#: results agree with Pinocchio to this (absolute, metres / radians / Jacobian entries)
PINOCCHIO_TOL = AGREEMENT_TOLERANCE


def npy_bytes(a) -> bytes:
    """``np.save`` of ``a``: an array as it is (hostile dtypes included, pickled if it must), anything
    else (nested lists) as float64."""
    buf = io.BytesIO()
    np.save(buf, a if isinstance(a, np.ndarray) else np.asarray(a, dtype=np.float64), allow_pickle=True)
    return buf.getvalue()


def write_npy(path: Path, a) -> Path:
    """``a`` saved as an ``.npy`` file at ``path`` (as :func:`npy_bytes`); returns ``path``."""
    path.write_bytes(npy_bytes(a))
    return path


def cube_stl(size: float = 0.1) -> bytes:
    """A cube of edge ``size`` metres centred on its origin, as binary STL bytes (needs trimesh)."""
    import trimesh

    return trimesh.creation.box(extents=(size, size, size)).export(file_type="stl")


def package_zip(package: str, urdf: str, meshes: dict[str, bytes]) -> bytes:
    """A ROS package as an upload archive (zip bytes): ``<package>/package.xml`` naming it,
    ``<package>/urdf/<package>.urdf`` holding ``urdf`` and every mesh at ``<package>/meshes/<name>``."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        zf.writestr(f"{package}/package.xml", f"<package><name>{package}</name></package>")
        zf.writestr(f"{package}/urdf/{package}.urdf", urdf)
        for name, data in meshes.items():
            zf.writestr(f"{package}/meshes/{name}", data)
    return buf.getvalue()


def refuse_files(monkeypatch) -> None:
    """From now on (until ``monkeypatch`` undoes it) any ``open`` -- ``builtins.open``, ``io.open``,
    ``os.open`` -- fails the test with an ``AssertionError`` naming the file."""
    def refuse(*args, **kwargs):
        raise AssertionError(f"a file was opened: {args[:1]}")

    monkeypatch.setattr(builtins, "open", refuse)
    monkeypatch.setattr(io, "open", refuse)
    monkeypatch.setattr(os, "open", refuse)


def run_cli(argv, capsys):
    """``kinematics ARGV`` in this process: ``(exit code, stdout, stderr)``; no traceback allowed."""
    from kinematics.cli import main

    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return code, out, err
