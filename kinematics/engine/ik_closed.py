"""Not the closed forms: a re-export kept only for two importers.

The closed forms of the IK families are :mod:`kinematics.engine.ik_fast` (the kernels the
every-solution IK runs), on the subproblems of :mod:`kinematics.engine.subproblems` (the set the
tests check). This module held an array-form copy of them that only tests reached; it is gone.
Its constants and duplicate filter now live in :mod:`kinematics.engine.ik_fast`; they are re-exported
here while ``kinematics/algorithms/ik_all.py`` and ``ik_families.py`` (being restructured) still
import them from here. New code imports :mod:`kinematics.engine.ik_fast`.
"""

from __future__ import annotations

from .ik_fast import (MAX_CANDIDATES, POS_INTERSECT_12, POS_INTERSECT_12_PRISMATIC, POS_PARALLEL_12,  # noqa: F401
                      POS_PARALLEL_23, distinct_rows)
