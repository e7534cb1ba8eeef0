"""The catalogue models the slow catalogue-wide tests check: a fixed sample by default (a spread of
the catalogue: a third of it, and one model of each kind), every model with ``KIN_TEST_FULL_CATALOGUE=1``
(CI before a release, ``kinematics check`` for the parity). The sample keeps ``make test`` within the
time the README states on a busy 2-core machine; it is the same in every run (no randomness)."""

from __future__ import annotations

import os

from kinematics.io.catalogue import default_catalogue

#: models every run checks: arms (UR5, Panda, Z1, SO-100), a humanoid, a mobile manipulator, legged robots,
#: continuous and mimic joints (PR2, the double pendulum), the file the catalogue refuses, and the DH presets' kinds
ALWAYS = ("ur5", "panda", "z1", "so100", "talos_reduced", "tiago_dual", "anymal_c", "solo12", "pr2",
          "double_pendulum_continuous", "ur3_unnamed", "ur5_dh", "puma560_standard", "stanford_arm")
#: and every STRIDE-th model of the rest, in catalogue order
STRIDE = 3
#: every model instead of the sample
FULL = os.environ.get("KIN_TEST_FULL_CATALOGUE", "") not in ("", "0")


def catalogue_ids() -> list[str]:
    """The ids the catalogue-wide tests run on (every id when :data:`FULL`)."""
    ids = list(default_catalogue().ids())
    if FULL:
        return ids
    keep = set(ALWAYS) | set(ids[::STRIDE])
    return [i for i in ids if i in keep]
