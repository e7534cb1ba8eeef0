"""Meshes named by a URDF are never opened: not by parsing, compiling, FK, Jacobians, nor by
the Pinocchio cross-check.

Each mesh path names a regular file that exists. Two detectors watch them:

- a Python audit hook records every ``open`` event of this process (``open``, ``io.open``,
  ``os.open``: what yourdfpy or trimesh would use);
- inotify (through libc) reports ``IN_OPEN`` / ``IN_ACCESS`` on the files by anyone, C/C++
  code included (Pinocchio's urdfdom, assimp), which Python's audit hooks never see.

Both detectors are shown to fire on a real open (positive controls), and inotify is shown
to catch yourdfpy when it *is* asked to load meshes.
"""

from __future__ import annotations

import ctypes
import io
import os
import struct
import sys
import threading

import numpy as np
import pytest

from kinematics import REFERENCES, compile_model, load_urdf, parse_urdf

IN_ACCESS, IN_OPEN = 0x001, 0x020
_EVENT_HEADER = struct.Struct("iIII")  # wd, mask, cookie, len

_STATE = threading.local()


def _hook(event, args):
    paths = getattr(_STATE, "paths", None)
    if paths is not None and event == "open" and args and isinstance(args[0], (str, bytes, os.PathLike)):
        p = os.fsdecode(args[0])
        if any(p.endswith(w) for w in paths):
            _STATE.hits.append(p)


sys.addaudithook(_hook)

_libc = ctypes.CDLL(None, use_errno=True)


class FileOpenWatch:
    """inotify on the given files: which of them anyone opened or read inside the block."""

    def __init__(self, files):
        self.files = [str(f) for f in files]

    def __enter__(self):
        self.fd = _libc.inotify_init1(os.O_NONBLOCK | os.O_CLOEXEC)
        if self.fd < 0:
            pytest.skip(f"inotify unavailable: {os.strerror(ctypes.get_errno())}")
        self.wd = {}
        for f in self.files:
            wd = _libc.inotify_add_watch(self.fd, os.fsencode(f), IN_OPEN | IN_ACCESS)
            assert wd >= 0, os.strerror(ctypes.get_errno())
            self.wd[wd] = f
        return self

    def __exit__(self, *exc):
        self.opened = []
        try:
            while True:
                try:
                    buf = os.read(self.fd, 65536)
                except BlockingIOError:
                    break
                off = 0
                while off < len(buf):
                    wd, mask, _, name_len = _EVENT_HEADER.unpack_from(buf, off)
                    off += _EVENT_HEADER.size + name_len
                    if mask & (IN_OPEN | IN_ACCESS) and self.wd[wd] not in self.opened:
                        self.opened.append(self.wd[wd])
        finally:
            os.close(self.fd)
        return False


class PythonOpens:
    """Records the ``open`` audit events of this thread for paths ending in one of ``names``."""

    def __init__(self, names):
        self.names = [str(n) for n in names]

    def __enter__(self):
        self.hits = []
        _STATE.paths, _STATE.hits = self.names, self.hits
        return self

    def __exit__(self, *exc):
        _STATE.paths = None
        return False


#: a valid (empty) ASCII STL, so a mesh loader that did open it would get a readable mesh
STL = b"solid empty\nendsolid empty\n"


@pytest.fixture
def mesh_robot(tmp_path, monkeypatch):
    """(urdf_path, meshes): a 2-DOF arm whose visuals and collisions name mesh files that exist."""
    (tmp_path / "meshes").mkdir()
    (tmp_path / "pkg" / "meshes").mkdir(parents=True)
    meshes = {
        "absolute": tmp_path / "abs.stl",
        "file_uri": tmp_path / "uri.dae",
        "relative": tmp_path / "meshes" / "rel.obj",
        "package": tmp_path / "pkg" / "meshes" / "pkg.stl",
        "collision": tmp_path / "col.stl",
    }
    for f in meshes.values():
        f.write_bytes(STL)
    monkeypatch.chdir(tmp_path)  # the relative mesh path resolves here
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path))  # package://pkg resolves here
    text = f"""<?xml version="1.0"?>
<robot name="meshy">
  <link name="base">
    <visual><geometry><mesh filename="{meshes['absolute']}"/></geometry></visual>
    <collision><geometry><mesh filename="{meshes['collision']}" scale="1 1 1"/></geometry></collision>
  </link>
  <link name="upper">
    <visual><origin xyz="0 0 0.1"/><geometry><mesh filename="file://{meshes['file_uri']}"/></geometry></visual>
  </link>
  <link name="lower">
    <visual><geometry><mesh filename="meshes/rel.obj"/></geometry></visual>
    <visual><geometry><mesh filename="package://pkg/meshes/pkg.stl"/></geometry></visual>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/><origin xyz="0 0 0.5"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/>
  </joint>
  <joint name="elbow" type="continuous">
    <parent link="upper"/><child link="lower"/><origin xyz="0 0 0.4" rpy="0.3 0 0"/><axis xyz="0 1 0"/>
  </joint>
</robot>
"""
    urdf = tmp_path / "meshy.urdf"
    urdf.write_text(text)
    return urdf, meshes


def test_meshes_are_never_opened(mesh_robot):
    from kinematics.verify import pinocchio as crosscheck

    urdf, meshes = mesh_robot
    Q = np.array([[0.3, -1.2], [1.0, 2.0]])
    with FileOpenWatch(meshes.values()) as os_watch, PythonOpens(meshes.values()) as py_watch:
        model = parse_urdf(urdf.read_text())
        model_from_file = load_urdf(urdf)
        poe = compile_model(model)
        T = poe.fk(Q, list(model.links))
        J = {r: poe.jacobian(Q, "lower", r) for r in REFERENCES}
        dev = crosscheck.compare_fk(model, Q)  # builds Pinocchio's model from the URDF text
        jdev = crosscheck.compare_jacobian(model, Q, "lower", jacobians=J)
        T_file = compile_model(model_from_file).fk(Q, list(model.links))
    assert py_watch.hits == []
    assert os_watch.opened == []
    # and the work really happened
    assert model.dof == 2 and T.shape == (2, 3, 4, 4) and np.array_equal(T_file, T)
    assert dev.worst < 1e-9 and jdev < 1e-9
    assert [v.kind for v in model.visuals["lower"]] == ["mesh", "mesh"]


def test_python_open_detector_fires(mesh_robot):
    """Positive control: a Python-level open of a mesh file is seen by both detectors."""
    urdf, meshes = mesh_robot
    target = meshes["absolute"]
    with FileOpenWatch(meshes.values()) as os_watch, PythonOpens(meshes.values()) as py_watch:
        assert target.read_bytes() == STL
    assert py_watch.hits == [str(target)]
    assert os_watch.opened == [str(target)]


def test_c_level_open_detector_fires(mesh_robot):
    """Positive control: an open from C (libc, as a C++ parser would) is seen by inotify
    although no Python audit event is raised."""
    urdf, meshes = mesh_robot
    target = meshes["package"]
    with FileOpenWatch(meshes.values()) as os_watch, PythonOpens(meshes.values()) as py_watch:
        fd = _libc.open(os.fsencode(target), os.O_RDONLY)
        assert fd >= 0
        os.close(fd)
    assert os_watch.opened == [str(target)]
    assert py_watch.hits == []


def test_detector_catches_a_mesh_loading_parser(mesh_robot):
    """Positive control on the real regression: yourdfpy asked to load meshes opens them."""
    import yourdfpy

    urdf, meshes = mesh_robot
    with FileOpenWatch(meshes.values()) as os_watch:
        try:  # the fake .dae / .obj contents may not parse: only the opening matters here
            yourdfpy.URDF.load(io.BytesIO(urdf.read_bytes()), load_meshes=True, build_scene_graph=True)
        except Exception:  # noqa: BLE001
            pass
    assert str(meshes["absolute"]) in os_watch.opened
