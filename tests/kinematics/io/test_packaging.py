"""An installed wheel carries what the library reads at run time: the DH presets of the catalogue."""

from __future__ import annotations

import subprocess
import sys
import zipfile

from kinematics.io.catalogue import DEFAULT_PRESETS_DIR, Catalogue
from tests.paths import REPO


def test_presets_are_package_data_of_the_wheel(tmp_path):
    presets = sorted(p.name for p in DEFAULT_PRESETS_DIR.glob("*.yaml"))
    assert len(presets) >= 12 and "scara.yaml" in presets
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q",
                            "-w", str(tmp_path), str(REPO)], capture_output=True, text=True, timeout=300,
                           cwd=tmp_path)
    assert build.returncode == 0, build.stderr
    (wheel,) = tmp_path.glob("kinematics_service-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    assert {f"kinematics/io/presets/{p}" for p in presets} <= names
    assert not any(n.startswith(("tests/", "bench/")) for n in names)


def test_catalogue_lists_the_packaged_presets():
    catalogue = Catalogue(robots_dir=None, presets_dir=DEFAULT_PRESETS_DIR)
    assert {e.id for e in catalogue.entries.values() if e.source == "preset"} >= {"scara", "rpr_example", "planar_2r"}
    assert catalogue.get("scara").dof == 4
