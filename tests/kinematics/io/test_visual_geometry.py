"""kinematics/io/visual_geometry.py: the <visual> elements, and which mesh bytes may be read."""

from __future__ import annotations

import pytest

from kinematics.errors import UnknownMeshError
from kinematics.io.collision_geometry import ArchiveMeshes, mesh_source, vouch_meshes
from kinematics.io.urdf import parse_urdf
from kinematics.io.visual_geometry import visual_geometry, visual_mesh
from tests.helpers import refuse_files

HOSTILE = ["/etc/passwd.stl", "file:///etc/hostname.stl", "package://pkg/../../etc/x.stl", "../../x.dae",
           "package://example-robot-data/robots/../../../etc/x.obj", "/dev/zero.stl", "C:/x.stl"]


def _urdf(names) -> str:
    visuals = "".join(f'<visual><geometry><mesh filename="{n}"/></geometry></visual>' for n in names)
    return f'<robot name="h"><link name="a">{visuals}<visual><geometry><sphere radius="0.1"/></geometry></visual></link></robot>'


def test_a_plain_upload_never_opens_a_mesh(monkeypatch):
    model = parse_urdf(_urdf(HOSTILE + ["package://example-robot-data/robots/ur_description/meshes/ur5/visual/base.dae"]))
    refuse_files(monkeypatch)
    g = visual_geometry(model)
    meshes = [v for v in g.visuals["a"] if v.kind == "mesh"]
    assert len(meshes) == len(HOSTILE) + 1 and all(v.mesh is None and v.path is None for v in meshes)
    assert g.meshes == 0 and len(g.warnings) == len(meshes) and all("not opened" in w for w in g.warnings)
    assert g.visuals["a"][-1].kind == "sphere"
    for index in (0, "0", "1"):
        with pytest.raises(UnknownMeshError):
            visual_mesh(model, index)


@pytest.mark.parametrize("index", ["-1", "1.0", "0x0", "../0", "0/..", " 0", "٣", "9" * 40, True, None, 1.0])
def test_only_a_decimal_index_in_range_is_served(catalogue, index):
    with pytest.raises(UnknownMeshError):
        visual_mesh(catalogue.get("ur5"), index)


def test_catalogue_meshes_are_the_package_files(catalogue):
    for mid in ("ur5", "panda"):
        model = catalogue.get(mid)
        root = mesh_source(model).root
        g = visual_geometry(model)
        assert g.source == "catalogue" and g.warnings == () and g.meshes > 0
        indexed = sorted(v.mesh for vs in g.visuals.values() for v in vs if v.kind == "mesh")
        assert indexed == list(range(g.meshes))
        for vs in g.visuals.values():
            for v in vs:
                if v.kind == "mesh":
                    assert v.path.is_relative_to(root)
                    assert visual_mesh(model, v.mesh) == (v.path.read_bytes(), v.format)
        with pytest.raises(UnknownMeshError):
            visual_mesh(model, g.meshes)


def test_an_archive_serves_its_members_only():
    model = parse_urdf(_urdf(["package://pkg/m/a.stl", "m/b.obj", "package://pkg/../../../etc/passwd.stl"]
                             + HOSTILE))
    vouch_meshes(model, ArchiveMeshes({"pkg/m/a.stl": b"solid a", "urdf/m/b.obj": b"v 0 0 0"}, {"pkg": "pkg"},
                                      base="urdf"))
    g = visual_geometry(model)
    assert g.meshes == 2
    assert visual_mesh(model, 0) == (b"solid a", "stl") and visual_mesh(model, "1") == (b"v 0 0 0", "obj")
    assert len(g.warnings) == 1 + len(HOSTILE)


def test_every_catalogue_model_reads_its_visuals(catalogue):
    """No model of the catalogue makes the reader fail; each mesh is served or named in a warning."""
    for mid in catalogue.ids():
        try:
            model = catalogue.get(mid)
        except Exception:  # a catalogue entry that does not load is the catalogue's own test
            continue
        g = visual_geometry(model)
        meshes = [v for vs in g.visuals.values() for v in vs if v.kind == "mesh"]
        assert sum(v.mesh is None for v in meshes) == sum("mesh " in w for w in g.warnings), mid
