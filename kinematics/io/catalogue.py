"""The bundled catalogue: every URDF of ``example-robot-data`` (the ``catalogue`` extra) plus the
DH presets of the top-level ``models/`` directory (in an installed wheel, the package data
``kinematics/models/``). Without example-robot-data the catalogue holds only the presets, and
says so (:attr:`Catalogue.notes`, and the message of an unknown id).

Ids are short, readable and stable: the file's stem, lower-cased, with ``_robot`` dropped
(``ur5_robot.urdf`` -> ``ur5``) and a few explicit names where stems collide
(:data:`ID_OVERRIDES`). Entries are listed cheaply; a model is parsed on first use and
then cached (models are immutable, so the cache is shared by every thread).
"""

from __future__ import annotations

import os
import re
import sysconfig
import threading
from dataclasses import dataclass
from pathlib import Path

from ..errors import UnknownModelError, did_you_mean, install_command
from ..model.robot import RobotModel
from .collision_geometry import PackageMeshes, vouch_meshes
from .dh_table import load_table, model_from_table
from .urdf import load_urdf

#: ids for files whose stems collide or read badly; keys are paths under ``robots/``
ID_OVERRIDES = {
    "anymal_b_simple_description/robots/anymal.urdf": "anymal_b",
    "anymal_b_simple_description/robots/anymal-kinova.urdf": "anymal_b_kinova",
    "anymal_c_simple_description/urdf/anymal.urdf": "anymal_c",
    "asr_twodof_description/urdf/TwoDofs.urdf": "asr_twodof",
    "alexander_description/urdf/alexander_v1.lowerBodyOnly.urdf": "alexander_v1_lower_body",
    "hector_description/robots/quadrotor_base.urdf": "hector_quadrotor",
    "g1_description/urdf/g1_29dof_rev_1_0.urdf": "g1_29dof",
    "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf": "g1_29dof_with_hand",
}

#: files of example-robot-data the catalogue leaves out (it lists only what loads), with the reason
UNLOADABLE = {
    "ur_description/urdf/ur3.urdf": "its <robot> element has no name (Pinocchio refuses it too); "
                                    "the same arm loads as ur3 (ur3_robot.urdf)",
}

_PACKAGE = Path(__file__).resolve().parents[1]


def _presets_dir() -> Path:
    """``kinematics/models`` of an installed wheel, else ``models/`` next to the package (a source
    tree: a checkout or an editable install)."""
    installed = _PACKAGE / "models"
    return installed if installed.is_dir() else _PACKAGE.parent / "models"


#: where the DH presets live (overridable with KIN_MODELS_DIR)
DEFAULT_PRESETS_DIR = _presets_dir()
#: what the catalogue says when example-robot-data is not installed
NO_EXAMPLE_ROBOT_DATA = ("example-robot-data is not installed, so the catalogue holds only the DH presets; "
                         f"for its URDFs (ur5, panda, talos, ...): {install_command('catalogue')}")


def example_robot_data_dir() -> Path | None:
    """``.../cmeel.prefix/share/example-robot-data/robots`` of the installed package (the
    ``catalogue`` extra), or None when it is not installed."""
    candidates = []
    for key in ("purelib", "platlib"):
        candidates.append(Path(sysconfig.get_paths()[key]) / "cmeel.prefix/share/example-robot-data/robots")
    try:  # the package also knows its own path
        import example_robot_data  # noqa: F401

        candidates.append(Path(example_robot_data.getModelPath("ur_description/urdf/ur5_robot.urdf")) / "robots")
    except Exception:  # noqa: BLE001 - optional convenience only
        pass
    for c in candidates:
        if c.is_dir():
            return c
    return None


def _make_id(rel: str) -> str:
    if rel in ID_OVERRIDES:
        return ID_OVERRIDES[rel]
    stem = Path(rel).stem.lower()
    stem = re.sub(r"[^a-z0-9]+", "_", stem).strip("_")
    return re.sub(r"_robot$", "", stem)


@dataclass(frozen=True)
class CatalogueEntry:
    """One bundled model: where it comes from and how to build it."""

    id: str
    name: str
    source: str  # "example-robot-data" | "preset"
    path: Path

    def load(self) -> RobotModel:
        if self.source == "preset":
            return model_from_table(load_table(self.path))
        model = load_urdf(self.path)
        robots = next((p for p in self.path.parents if p.name == "robots"), None)
        return vouch_meshes(model, PackageMeshes(robots)) if robots is not None else model


class Catalogue:
    """The bundled models, listed at construction and built lazily (thread-safe)."""

    def __init__(self, robots_dir: Path | None = None, presets_dir: Path | None = None):
        self.entries: dict[str, CatalogueEntry] = {}
        #: what a user should know about this catalogue (a missing example-robot-data)
        self.notes: list[str] = []
        #: the files left out of the listing, with the reason (:data:`UNLOADABLE`)
        self.skipped: dict[str, str] = {}
        if robots_dir is None:
            robots_dir = example_robot_data_dir()
            if robots_dir is None:
                self.notes.append(NO_EXAMPLE_ROBOT_DATA)
        if robots_dir is not None:
            for path in sorted(Path(robots_dir).rglob("*.urdf")):
                rel = path.relative_to(robots_dir).as_posix()
                if rel in UNLOADABLE:
                    self.skipped[rel] = UNLOADABLE[rel]
                    continue
                eid = _make_id(rel)
                if eid in self.entries:
                    raise RuntimeError(f"catalogue id collision: {eid!r} ({rel} and {self.entries[eid].path})")
                self.entries[eid] = CatalogueEntry(eid, path.stem, "example-robot-data", path)
        if presets_dir is None:
            presets_dir = Path(os.environ.get("KIN_MODELS_DIR", DEFAULT_PRESETS_DIR))
        if Path(presets_dir).is_dir():
            for path in sorted(Path(presets_dir).glob("*.y*ml")) + sorted(Path(presets_dir).glob("*.json")):
                eid = _make_id(path.name)
                if eid in self.entries:
                    raise RuntimeError(f"catalogue id collision: preset {path.name} and {self.entries[eid].path}")
                self.entries[eid] = CatalogueEntry(eid, path.stem, "preset", path)
        self._models: dict[str, RobotModel] = {}
        self._lock = threading.Lock()

    def ids(self) -> list[str]:
        return list(self.entries)

    def __contains__(self, model_id: str) -> bool:
        return model_id in self.entries

    def entry(self, model_id: str) -> CatalogueEntry:
        try:
            return self.entries[model_id]
        except KeyError:
            raise UnknownModelError(f"unknown model {model_id!r}" + did_you_mean(model_id, self.entries, "bundled model ids")
                                    + "".join(f" ({note})" for note in self.notes)) from None

    def get(self, model_id: str) -> RobotModel:
        """The model of ``model_id``, parsed on first use (raises UnknownModelError, URDFError)."""
        model = self._models.get(model_id)
        if model is None:
            entry = self.entry(model_id)
            with self._lock:
                model = self._models.get(model_id)
                if model is None:
                    model = entry.load()
                    self._models[model_id] = model
        return model


_default: Catalogue | None = None


def default_catalogue() -> Catalogue:
    """The process-wide catalogue (built on first call)."""
    global _default
    if _default is None:
        _default = Catalogue()
    return _default
