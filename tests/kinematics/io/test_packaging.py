"""An installed wheel carries what the library reads at run time: the DH presets of the
top-level ``models/`` directory, as the package data ``kinematics/models``."""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile

from kinematics.io.catalogue import DEFAULT_PRESETS_DIR, Catalogue
from tests.paths import REPO


def test_the_presets_live_in_the_top_level_models_directory():
    assert DEFAULT_PRESETS_DIR == REPO / "models"  # a source tree: the checkout's models/
    assert not (REPO / "kinematics" / "io" / "presets").exists()


#: what a wheel is built from (what the Dockerfile copies too)
SOURCES = ("pyproject.toml", "setup.py", "README.md", "kinematics", "app", "models")


def test_presets_are_package_data_of_the_wheel(tmp_path):
    presets = sorted(p.name for p in DEFAULT_PRESETS_DIR.glob("*.yaml"))
    assert len(presets) >= 12 and "scara.yaml" in presets
    # from a clean copy, as from a fresh clone: an in-tree build/ keeps files a build once copied
    src = tmp_path / "src"
    src.mkdir()
    for name in SOURCES:
        if (REPO / name).is_dir():
            shutil.copytree(REPO / name, src / name, ignore=shutil.ignore_patterns("__pycache__"))
        else:
            shutil.copy(REPO / name, src / name)
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q",
                            "-w", str(tmp_path), str(src)], capture_output=True, text=True, timeout=300,
                           cwd=tmp_path)
    assert build.returncode == 0, build.stderr
    (wheel,) = tmp_path.glob("kinematics_service-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    assert {f"kinematics/models/{p}" for p in presets} <= names
    assert "app/static/viewer/viewer.js" in names and "kinematics/algorithms/symbolic/__init__.py" in names
    assert not any(n.startswith(("tests/", "bench/", "models/")) for n in names)
    assert "kinematics/algorithms/symbolic.py" not in names and not any("/presets/" in n for n in names)
    # unpacked as pip installs it, the catalogue finds the presets inside the package
    site = tmp_path / "site"
    zipfile.ZipFile(wheel).extractall(site)
    code = ("from kinematics.io.catalogue import DEFAULT_PRESETS_DIR as d; "
            "print(d); assert sorted(p.name for p in d.glob('*.yaml')) == %r" % presets)
    r = subprocess.run([sys.executable, "-I", "-c", f"import sys; sys.path.insert(0, {str(site)!r}); {code}"],
                       capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == str(site / "kinematics" / "models")


def test_catalogue_lists_the_packaged_presets():
    catalogue = Catalogue(robots_dir=None, presets_dir=DEFAULT_PRESETS_DIR)
    assert {e.id for e in catalogue.entries.values() if e.source == "preset"} >= {"scara", "rpr_example", "planar_2r"}
    assert catalogue.get("scara").dof == 4
