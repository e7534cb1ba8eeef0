"""Collision geometry: primitives always; meshes only from the installed packages or inside an
uploaded archive; hostile mesh names never read."""

from __future__ import annotations

import io
import tarfile
import zipfile
import gzip

import numpy as np
import pytest

from kinematics.errors import ArchiveError
from kinematics.io import archive
from kinematics.io.collision_geometry import (ArchiveMeshes, PackageMeshes, collision_geometry, mesh_source,
                                              with_geometry_warnings)
from kinematics.io.description import load_description, model_with_format
from kinematics.io.urdf import parse_urdf
from tests.helpers import cube_stl, refuse_files


def _robot(collisions: str, name: str = "a") -> str:
    return f'<robot name="r"><link name="{name}">{collisions}</link></robot>'


def _mesh(filename: str, scale: str | None = None) -> str:
    s = f' scale="{scale}"' if scale else ""
    return f'<collision><geometry><mesh filename="{filename}"{s}/></geometry></collision>'


def test_primitives_with_origin_in_document_order():
    m = parse_urdf(_robot(
        '<collision><origin xyz="1 2 3" rpy="0 0 1.5707963267948966"/><geometry><box size="0.1 0.2 0.3"/></geometry></collision>'
        '<collision><geometry><cylinder radius="0.05" length="0.4"/></geometry></collision>'
        '<collision><geometry><sphere radius="0.07"/></geometry></collision>'
        '<collision><geometry><capsule radius="0.02" length="0.3"/></geometry></collision>'))
    g = collision_geometry(m)
    kinds = [(s.kind, s.size) for s in g.shapes["a"]]
    assert kinds == [("box", (0.1, 0.2, 0.3)), ("cylinder", (0.05, 0.4)), ("sphere", (0.07,)), ("capsule", (0.02, 0.3))]
    T = g.shapes["a"][0].origin
    np.testing.assert_allclose(T[:3, 3], [1, 2, 3])
    np.testing.assert_allclose(T[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)
    assert g.warnings == ()


def test_bad_primitives_are_skipped_and_named():
    m = parse_urdf(_robot('<collision><geometry><sphere radius="-1"/></geometry></collision>'
                          '<collision><geometry><box size="1 2"/></geometry></collision>'
                          '<collision><geometry><sphere radius="0.1"/></geometry></collision>'))
    g = collision_geometry(m)
    assert [s.kind for s in g.shapes["a"]] == ["sphere"]
    assert len(g.warnings) == 2 and all("link 'a'" in w for w in g.warnings)


HOSTILE = ["/etc/passwd.stl", "/dev/zero.stl", "file:///etc/shadow.stl", "package://pkg/../../../etc/x.stl",
           "../outside.stl", "http://example.com/x.stl", "package:///dev/zero.stl"]


@pytest.fixture
def no_open(monkeypatch):
    """Fail the test if any file is opened (builtins.open, os.open, io.open)."""
    refuse_files(monkeypatch)


@pytest.mark.parametrize("name", HOSTILE + ["package://ur_description/meshes/ur5/collision/base.stl", "meshes/a.stl"])
def test_a_plain_upload_never_opens_a_mesh(name, no_open):
    m = parse_urdf(_robot(_mesh(name) + '<collision><geometry><sphere radius="0.1"/></geometry></collision>'))
    g = collision_geometry(m)
    assert [s.kind for s in g.shapes["a"]] == ["sphere"]  # the link keeps its other shapes
    assert len(g.warnings) == 1 and repr(name) in g.warnings[0] and "not opened" in g.warnings[0]


def test_a_plain_upload_s_warnings_name_the_mesh():
    loaded = load_description(_robot(_mesh("package://pkg/meshes/arm.stl")).encode())
    assert mesh_source(loaded.model) is None
    assert any("'package://pkg/meshes/arm.stl'" in w and "not opened" in w for w in loaded.model.warnings)


def test_package_meshes_stay_inside_their_root(tmp_path):
    root = tmp_path / "robots"
    (root / "pkg" / "meshes").mkdir(parents=True)
    (root / "pkg" / "meshes" / "ok.stl").write_bytes(b"solid x\nendsolid x\n")
    secret = tmp_path / "secret.stl"
    secret.write_bytes(b"secret")
    (root / "pkg" / "meshes" / "link.stl").symlink_to(secret)  # a link leaving the packages
    (root / "pkg" / "meshes" / "dev.stl").symlink_to("/dev/zero")
    src = PackageMeshes(root)
    path, data = src.resolve("package://pkg/meshes/ok.stl")
    assert path == (root / "pkg/meshes/ok.stl").resolve() and data is None
    assert src.resolve("package://example-robot-data/robots/pkg/meshes/ok.stl")[0] == path
    for bad in HOSTILE + ["package://pkg/meshes/link.stl", "package://pkg/meshes/dev.stl",
                          "package://pkg/meshes/missing.stl", str(secret)]:
        with pytest.raises(LookupError):
            src.resolve(bad)


def test_catalogue_models_resolve_their_meshes(catalogue):
    for mid in ("ur5", "panda"):
        g = collision_geometry(catalogue.get(mid))
        assert g.source == "catalogue" and g.warnings == ()
        meshes = [s for shapes in g.shapes.values() for s in shapes if s.kind == "mesh"]
        assert meshes and all(s.path is not None and s.path.is_file() and s.data is None for s in meshes)


def test_the_same_text_uploaded_gets_no_meshes(catalogue):
    """Trust goes with the catalogue's model object, not with its text."""
    text = catalogue.get("ur5").urdf
    g = collision_geometry(parse_urdf(text))
    assert g.shapes.get("ee_link") is not None  # its box primitive
    assert all(s.kind != "mesh" for shapes in g.shapes.values() for s in shapes)
    assert sum("not opened" in w for w in g.warnings) == 7


ARCHIVE_URDF = """<robot name="arm">
  <link name="base"><collision><geometry><mesh filename="package://arm_description/meshes/cube.stl" scale="2 2 2"/></geometry></collision></link>
  <link name="tip"><collision><geometry><mesh filename="../meshes/cube.stl"/></geometry></collision>
    <collision><geometry><mesh filename="/etc/hosts.stl"/></geometry></collision></link>
  <joint name="j" type="prismatic"><parent link="base"/><child link="tip"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="1" effort="1" velocity="1"/></joint>
</robot>"""


def _zip(members: dict[str, bytes], symlink: str | None = None) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for name, data in members.items():
            zf.writestr(name, data)
        if symlink:
            info = zipfile.ZipInfo(symlink)
            info.external_attr = (0o120777 << 16)
            zf.writestr(info, "/etc/passwd")
    return buf.getvalue()


def _package(extra: dict[str, bytes] | None = None) -> dict[str, bytes]:
    return {"arm_description/package.xml": b"<package><name>arm_description</name></package>",
            "arm_description/urdf/arm.urdf": ARCHIVE_URDF.encode(),
            "arm_description/meshes/cube.stl": cube_stl(), **(extra or {})}


def test_an_archive_s_meshes_come_from_its_members(monkeypatch):
    loaded = load_description(_zip(_package()))
    model = model_with_format(loaded)
    refuse_files(monkeypatch)  # the geometry and its check read the archive's bytes, no file
    assert isinstance(mesh_source(model), ArchiveMeshes)
    g = collision_geometry(model)
    base, tip = g.shapes["base"], g.shapes["tip"]
    assert base[0].data == tip[0].data and base[0].path is None and base[0].size == (2.0, 2.0, 2.0)
    assert len(tip) == 1  # the absolute name is not read
    assert any("'/etc/hosts.stl'" in w for w in model.warnings)
    from kinematics.algorithms import self_collision

    cm = self_collision.geometry(model)  # the coal objects: built from the archive's bytes
    monkeypatch.undo()  # (the engine's first FK call reads its own package metadata)
    assert cm.links == ("base", "tip")
    # base: a 0.2 m cube (0.1 scaled by 2) at the origin; tip: a 0.1 m cube moved along x
    r = cm.check([[0.14], [0.16]], distance=True)
    assert r.colliding.tolist() == [True, False]
    assert r.min_distance[1] == pytest.approx(0.16 - 0.1 - 0.05, abs=1e-6)  # coal's GJK on meshes


def test_archive_symlink_members_are_refused():
    with pytest.raises(ArchiveError, match="symbolic link"):
        archive.read_meshes(_zip(_package(), symlink="arm_description/meshes/evil.stl"))


def test_archive_meshes_over_the_caps_are_left_out():
    big = _zip(_package({"arm_description/meshes/huge.stl": b"\0" * 4096}))
    files, warnings = archive.read_meshes(big, mesh_limits=archive.MeshLimits(max_mesh_bytes=2048, max_total_bytes=1 << 20))
    assert "arm_description/meshes/huge.stl" not in files and "arm_description/meshes/cube.stl" in files
    assert any("huge.stl" in w for w in warnings)


def test_a_decompression_bomb_of_meshes_is_refused():
    raw = io.BytesIO()
    with tarfile.open(fileobj=raw, mode="w") as tf:
        data = b"\0" * (8 << 20)
        info = tarfile.TarInfo("pkg/meshes/bomb.stl")
        info.size = len(data)
        tf.addfile(info, io.BytesIO(data))
    bomb = gzip.compress(raw.getvalue())
    assert len(bomb) < 64 << 10
    with pytest.raises(archive.ArchiveTooLargeError):
        archive.read_meshes(bomb, limits=archive.ArchiveLimits(max_stream_bytes=1 << 20))
    files, warnings = archive.read_meshes(bomb, mesh_limits=archive.MeshLimits(max_mesh_bytes=1 << 20))
    assert files == {} and "bomb.stl" in warnings[0]


def test_geometry_warnings_keep_the_source(catalogue):
    m = catalogue.get("ur5")
    assert with_geometry_warnings(m) is m  # nothing left out: the same object


BILLION_LAUGHS_DAE = b"""<?xml version="1.0"?>
<!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">]>
<COLLADA><asset>&lol2;</asset></COLLADA>"""


def test_archive_obj_and_dae_meshes_and_a_hostile_dae():
    import trimesh

    from kinematics.algorithms import self_collision

    box = trimesh.creation.box(extents=(0.1, 0.1, 0.1))
    urdf = """<robot name="formats">
      <link name="a"><collision><geometry><mesh filename="package://fmt/meshes/a.obj"/></geometry></collision></link>
      <link name="b"><collision><geometry><mesh filename="package://fmt/meshes/b.dae" scale="2 2 2"/></geometry></collision></link>
      <link name="c"><collision><geometry><mesh filename="package://fmt/meshes/lol.dae"/></geometry></collision>
        <collision><geometry><sphere radius="0.01"/></geometry></collision></link>
      <joint name="x" type="prismatic"><parent link="a"/><child link="b"/><origin xyz="0 0 9"/><axis xyz="1 0 0"/>
        <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="y" type="fixed"><parent link="a"/><child link="c"/><origin xyz="0 0 -9"/></joint></robot>"""
    data = _zip({"fmt/package.xml": b"<package><name>fmt</name></package>", "fmt/urdf/f.urdf": urdf.encode(),
                 "fmt/meshes/a.obj": box.export(file_type="obj").encode(),
                 "fmt/meshes/b.dae": box.export(file_type="dae"), "fmt/meshes/lol.dae": BILLION_LAUGHS_DAE})
    model = model_with_format(load_description(data))
    cm = self_collision.geometry(model)
    assert cm.links == ("a", "b", "c")
    assert any("lol.dae" in w and "not safe" in w for w in cm.warnings)  # left out, the sphere kept
    # b (a 0.2 m cube) 9 m above a (0.1 m): distance 9 - 0.05 - 0.1
    r = cm.check([[0.0]], [("a", "b")], distance=True)
    assert r.min_distance[0] == pytest.approx(9 - 0.05 - 0.1, abs=1e-6)
