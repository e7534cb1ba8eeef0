"""The registry of IK kernels: a family's ``kernel`` name -> how its candidates are made.

A :class:`~kinematics.algorithms.ik_families.Family` names its kernel (``fam.kernel``);
:func:`~kinematics.algorithms.ik_all.all_solutions` looks it up here instead of testing names:

- a **compiled** kernel (:mod:`kinematics.engine.ik_fast`) writes at most ``candidates`` candidates
  per target into preallocated arrays, row range by row range on the engine's threads, inside the
  compiled pass (:func:`Kernel.bind` gives the writer of one family: its ideal chain's arrays read
  once);
- a **NumPy** kernel (:mod:`kinematics.algorithms.ik_general`: the general 6R elimination and the
  short chains' closed forms) answers every candidate of a batch at once
  (:func:`~kinematics.algorithms.ik_general.family_candidates`), and then goes through the same
  compiled polish.

``position``: the kernel solves a position alone (``mode="position"``; the 2R's). A new kernel is
one module with its function and one :func:`register` call (a new family: a detector in
:mod:`kinematics.algorithms.ik_families`, ``register_family``, naming its kernel).

>>> KERNELS["three_parallel"].compiled, KERNELS["three_parallel"].candidates, KERNELS["planar_2r"].position
(True, 8, True)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from ..engine import ik_fast
from . import ik_general

#: a bound writer of candidates: ``write(G, width, out, count, flag)`` over one row range of targets
Writer = Callable[[np.ndarray, float, np.ndarray, np.ndarray, np.ndarray], None]


@dataclass(frozen=True)
class Kernel:
    """One IK kernel: ``name`` (a family's ``kernel``), ``compiled`` (writes candidates row range by
    row range; else NumPy candidates of the whole batch), ``candidates`` (at most, per target, of a
    compiled kernel), ``position`` (solves a position alone), ``bind(fam) -> Writer`` (compiled)."""

    name: str
    compiled: bool
    candidates: int = 0
    position: bool = False
    bind: Callable[[Any], Writer] | None = None


#: every kernel, by name
KERNELS: dict[str, Kernel] = {}


def register(kernel: Kernel) -> Kernel:
    """Add ``kernel`` to :data:`KERNELS` (one line per kernel)."""
    KERNELS[kernel.name] = kernel
    return kernel


def kernel_of(fam: Any) -> Kernel | None:
    """The kernel of a family (None: no kernel, the multistart search)."""
    return KERNELS.get(fam.kernel) if fam.kernel else None


def _ideal(fam: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return (np.ascontiguousarray(fam.ideal.h), np.ascontiguousarray(fam.ideal.r), np.ascontiguousarray(fam.centre))


def _three_parallel(fam: Any) -> Writer:
    h, r, centre = _ideal(fam)
    return lambda G, width, out, n, flag: ik_fast.three_parallel(G, h, r, centre, width, out, n, flag)


def _spherical_wrist(fam: Any) -> Writer:
    h, r, centre = _ideal(fam)
    prismatic3 = not bool(fam.ideal.revolute[2])
    return lambda G, width, out, n, flag: ik_fast.spherical_wrist(G, h, r, prismatic3, centre, fam.position, width,
                                                                   out, n, flag)


def _spherical_wrist_search(fam: Any) -> Writer:
    h, r, centre = _ideal(fam)
    return lambda G, width, out, n, flag: ik_fast.spherical_wrist_search(G, h, r, centre, ik_fast.SEARCH_SAMPLES,
                                                                          out, n, flag)


register(Kernel("three_parallel", True, ik_fast.FAMILY_CANDIDATES, bind=_three_parallel))
register(Kernel("spherical_wrist", True, ik_fast.FAMILY_CANDIDATES, bind=_spherical_wrist))
register(Kernel("spherical_wrist_search", True, ik_fast.MAX_CANDIDATES, bind=_spherical_wrist_search))
for _name in ik_general.KERNELS:
    register(Kernel(_name, False, position=_name in ik_general.POSITION_KERNELS))
