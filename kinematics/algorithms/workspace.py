"""Workspace: the reachable set of a link (or of a point or tool frame on it), by sampling.

**Sampling.** Configurations are drawn uniformly within the joint limits (a joint without
limits, a continuous one, over ``[-π, π]``; only the joints on the path to the link are drawn,
a mimic joint follows its leader), from ``numpy.random.default_rng(random_seed)`` in chunks of
:data:`CHUNK`, and run through the compiled kernel (:mod:`kinematics.engine.workspace`): the
frame's position and the **manipulability** there, the product of the singular values of the
frame's ``local_world_aligned`` Jacobian over the path's joints, 6 x k (``measure="pose"``,
the default) or its 3 x k position rows (``measure="position"``); for k joints fewer than the
rows, the product of the k singular values (``sqrt(det(J^T J))``), as :func:`conditioning`.
Memory: the cloud itself (N x 4 numbers) and one chunk of configurations.

**Dimension.** The cloud's principal extents (singular values of the centred positions of up to
:data:`PCA_SAMPLES` of them) tell whether it fills space (3), a plane (2: a planar arm), a curve
or a point. Extents below ``FLAT_TOLERANCE`` times the largest (or 1e-12 m) are flat.

**Volume (area).** Occupancy on a grid aligned with the world axes (a planar cloud: with its
plane, the world axes when the plane is a coordinate plane) anchored at the cloud's bounding
box: each axis of extent ``e`` has an even number ``n = 2 ceil(e / 2h)`` of cells of size
``e / n <= h`` (``h``: the ``voxel`` edge), so that whole cells tile the box. Where the samples
are **dense** for ``h`` (at least :data:`MIN_SAMPLES_PER_CELL` per occupied cell, and the cells
at ``2h`` at most :data:`MAX_COARSE_RATIO` times the volume of those at ``h``), every cell the
set touches holds a sample: the occupied cells at size ``h`` overestimate the set by a layer
along its boundary proportional to ``h``, the cells at ``2h`` (pairs of the same grid) by twice
that layer, so the estimate is the Richardson extrapolation ``V = 2 V(h) - V(2h)`` (exact for a
box, whose cells are all full; the boundary layer of a curved set cancels to first order), and
never less than the interior cells (occupied with all their face neighbours). Where they are
**sparse** (a fine voxel: most samples alone in their cell, most cells between them empty), the
extrapolation would subtract what the samples never reached and fall to nothing; the estimate
is then the occupied volume ``V(h)`` itself, the most the samples show (below the set's volume,
whose cells they have not all found), and the answer is not converged, with the advice to give
a larger voxel or more samples. The default ``h`` makes the cells of the bounding box about
``N / SAMPLES_PER_CELL`` (so that an occupied cell holds samples). The same estimate over the
first N/4, N/2 and N samples is the **convergence**: when the samples are dense at N/2 and N and
the two estimates agree within :data:`CONVERGED_TOLERANCE`, the workspace is ``converged``;
otherwise ``advice`` says what to change.

**Dexterity map.** Per occupied cell (size ``h``): its centre and the best manipulability of
the samples in it.

The 2R planar arm (``a1 = 0.5``, ``a2 = 0.4``, full turns) reaches the annulus
``0.1 <= r <= 0.9``, of area ``π (0.9² - 0.1²) = 2.513``:

>>> from kinematics.io import default_catalogue
>>> ws = workspace(default_catalogue().get("planar_2r"), "tool", samples=200_000)
>>> ws.dimension, round(ws.area, 2), round(ws.reach, 4)
(2, 2.51, 0.9)
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..engine import cancel
from ..engine.poe import compile_model
from ..engine.workspace import MEASURE_POSE, MEASURE_POSITION, sample_frame
from ..errors import KinematicsError
from ..model.robot import RobotModel

#: configurations drawn per pass (bounds the scratch memory)
CHUNK = 65_536
#: below this many samples per occupied cell the grid is sparse for its voxel (no extrapolation)
MIN_SAMPLES_PER_CELL = 8
#: the grid is sparse (or the set thinner than the voxel) when the cells at 2h exceed those at h by more
MAX_COARSE_RATIO = 1.5
#: converged: the estimates at N/2 and N differ by at most this fraction of the latter
CONVERGED_TOLERANCE = 0.05
#: samples when the caller names none
DEFAULT_SAMPLES = 100_000
#: the default voxel makes the cells of the bounding box about samples / this
SAMPLES_PER_CELL = 16
#: positions used to find the cloud's principal extents
PCA_SAMPLES = 100_000
#: an extent below this fraction of the largest is flat
FLAT_TOLERANCE = 1e-9
#: most cells of one grid (the voxel is refused as too small beyond)
MAX_CELLS = 2**40
#: the measures of manipulability
MEASURES = {"pose": MEASURE_POSE, "position": MEASURE_POSITION}


@dataclass(frozen=True, eq=False)
class Workspace:
    """A sampled workspace (arrays in the root frame; lengths in metres).

    points (N, 3), manipulability (N,): the samples. bounding_box (2, 3): min and max.
    reach: the largest distance of a sample from the root frame's origin. dimension: 3 (a
    volume), 2 (planar), 1 or 0. volume (m³; 0 unless dimension 3), area (m²; for dimension
    <= 2, else None). voxel: the edge h asked for (or chosen); cell: the grid's cell edges
    along ``axes`` (each <= h; 0 along a flat axis). axes (3, 3): the grid's axes (rows, world
    coordinates); origin (3,): its corner. convergence: ``(samples, estimate)`` at N/4, N/2, N
    (volume, or area when planar). voxel_index (M, 3), voxel_centers (M, 3),
    voxel_manipulability (M,): the dexterity map (best manipulability per occupied cell).
    converged: the samples are dense for the voxel and the estimate settled (module docstring);
    advice: when not converged, what to change (None otherwise). occupied: ``V(h)``, the volume
    (area) of the occupied cells.
    """

    link: str
    measure: str
    points: np.ndarray
    manipulability: np.ndarray
    bounding_box: np.ndarray
    reach: float
    dimension: int
    volume: float
    area: float | None
    voxel: float
    cell: np.ndarray
    axes: np.ndarray
    origin: np.ndarray
    convergence: list[tuple[int, float]]
    voxel_index: np.ndarray
    voxel_centers: np.ndarray
    voxel_manipulability: np.ndarray
    random_seed: int = 0
    convergence_curve: list[tuple[int, float]] = field(default_factory=list)  # the estimate from N/16 to N samples
    converged: bool = False
    advice: str | None = None
    occupied: float = 0.0
    collision_free: bool = False  # only samples free of self-collision were kept
    dropped: int = 0  # samples drawn and left out (in self-collision)

    @property
    def samples(self) -> int:
        return int(self.points.shape[0])

    @property
    def planar(self) -> bool:
        return self.dimension <= 2


def sampling_bounds(model: RobotModel, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds of the q columns ``cols``: the limits; ``[-π, π]`` for a revolute or
    continuous joint without them; a prismatic joint without limits is refused."""
    lo = np.array(model.lower_limits, dtype=float)[cols]
    hi = np.array(model.upper_limits, dtype=float)[cols]
    for i, c in enumerate(cols):
        if np.isfinite(lo[i]) and np.isfinite(hi[i]):
            continue
        joint = model.joint_map[model.joint_names[c]]
        if joint.type == "prismatic":
            raise KinematicsError(f"joint {joint.name!r} is prismatic without limits: the workspace needs its range")
        lo[i] = max(lo[i], -math.pi) if np.isfinite(lo[i]) else -math.pi
        hi[i] = min(hi[i], math.pi) if np.isfinite(hi[i]) else math.pi
        if hi[i] < lo[i]:
            lo[i], hi[i] = (lo[i], lo[i] + 2 * math.pi) if np.isfinite(model.lower_limits[c]) else (hi[i] - 2 * math.pi, hi[i])
    return lo, hi


def sample_workspace(model: RobotModel, link: str, samples: int, *, tool: np.ndarray | None = None,
                     measure: str = "pose", random_seed: int = 0,
                     progress: Callable[[int], None] | None = None,
                     keep: Callable[[np.ndarray], np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(points (N, 3), manipulability (N,))`` of ``link`` (times ``tool``) at ``samples`` uniform
    configurations (``progress(n)`` after each chunk of n). ``keep``: None, or ``keep(Q)`` (m, dof)
    -> (m,) bool, the samples to keep (e.g. those free of self-collision): the answer then has the
    kept samples only, in their order (the draws are the same, so the kept samples are a subset of
    the unfiltered answer's)."""
    if measure not in MEASURES:
        raise KinematicsError(f"measure: {measure!r} is not one of {', '.join(MEASURES)}")
    if samples < 1:
        raise KinematicsError(f"samples: {samples}; give at least 1")
    poe = compile_model(model)
    li = int(poe.link_indices([link])[0])
    kernel = poe.kernel
    cols = kernel.path_columns(li)
    lo, hi = sampling_bounds(model, cols)
    rng = np.random.default_rng(random_seed)
    P = np.empty((samples, 3))
    M = np.empty(samples)
    Q = np.zeros((min(CHUNK, samples), model.dof))
    kept = 0
    for a in range(0, samples, CHUNK):
        cancel.check()  # a cancelled or timed-out request stops here (kinematics.engine.cancel)
        m = min(CHUNK, samples - a)
        Qc = Q[:m]
        if len(cols):
            Qc[:, cols] = rng.uniform(lo, hi, (m, len(cols)))
        sample_frame(kernel, Qc, li, tool, MEASURES[measure], P[a : a + m], M[a : a + m])
        if keep is not None:
            mask = np.asarray(keep(Qc), dtype=bool)
            k = int(mask.sum())
            P[kept : kept + k], M[kept : kept + k] = P[a : a + m][mask], M[a : a + m][mask]
            kept += k
        if progress is not None:
            progress(m)
    if keep is not None:
        return P[:kept].copy(), M[:kept].copy()
    return P, M


def _frame_of(P: np.ndarray) -> tuple[int, np.ndarray]:
    """``(dimension, axes (3, 3))``: how many principal extents of the cloud are not flat, and the
    axes of its grid (the world axes, or for a flat cloud its principal axes, flat ones last;
    a flat direction along a world axis keeps the world axes)."""
    sub = P[:: max(1, P.shape[0] // PCA_SAMPLES)]
    c = sub - sub.mean(axis=0)
    if c.shape[0] < 3:  # zero rows change no singular value: three axes even from one or two samples
        c = np.vstack([c, np.zeros((3 - c.shape[0], 3))])
    _, s, Vt = np.linalg.svd(c / math.sqrt(max(len(sub), 1)), full_matrices=False)
    tol = max(FLAT_TOLERANCE * (s[0] if s.size else 0.0), 1e-12)
    dim = int(np.count_nonzero(s > tol))
    if dim == 3:
        return 3, np.eye(3)
    axes = np.array(Vt, dtype=float)
    flat = axes[dim:]
    # prefer the world axes when every flat direction is one of them
    world = [int(np.argmax(np.abs(f))) for f in flat]
    if all(abs(abs(f[w]) - 1.0) <= 1e-9 for f, w in zip(flat, world)) and len(set(world)) == len(world):
        keep = [i for i in range(3) if i not in world]
        return dim, np.eye(3)[keep + world]
    return dim, axes


@dataclass(frozen=True)
class _Grid:
    origin: np.ndarray  # (3,) corner, world
    axes: np.ndarray  # (3, 3) rows
    counts: np.ndarray  # (3,) cells per axis (even; 1 along a flat axis)
    cell: np.ndarray  # (3,) edges (0 along a flat axis)
    dim: int


def _coordinates(P: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """Coordinates (N, 3) of world positions along ``axes`` (rows), without a product for the world axes."""
    return P if np.array_equal(axes, np.eye(3)) else np.ascontiguousarray(np.einsum("nj,ij->ni", P, axes))


def _grid(X: np.ndarray, dim: int, axes: np.ndarray, h: float) -> _Grid:
    """The grid of coordinates ``X`` (N, 3) along ``axes`` with cells of edge at most ``h``."""
    lo, hi = X.min(axis=0), X.max(axis=0)
    extent = hi - lo
    counts = np.ones(3, dtype=np.int64)
    cell = np.zeros(3)
    with np.errstate(over="ignore"):  # a tiny h makes these huge, or infinite: refused below
        halves = [float(extent[i] / (2 * h)) for i in range(dim)]
    wanted = float(np.prod([2.0 * max(1.0, x) for x in halves])) if dim else 1.0
    if not math.isfinite(wanted) or wanted > MAX_CELLS:
        raise KinematicsError(f"voxel: {h:g} m makes a grid of {wanted:.3g} cells over the "
                              f"{extent.max():.3g} m workspace; give a larger voxel")
    for i in range(dim):
        n = 2 * max(1, math.ceil(halves[i]))
        counts[i] = n
        cell[i] = extent[i] / n
    if float(np.prod(counts.astype(float))) > MAX_CELLS:
        raise KinematicsError(f"voxel: {h:g} m makes a grid of {np.prod(counts.astype(float)):.3g} cells over the "
                              f"{extent.max():.3g} m workspace; give a larger voxel")
    return _Grid(lo @ axes, axes, counts, cell, dim)


def _cells(X: np.ndarray, grid: _Grid) -> np.ndarray:
    """(N, 3) int64 cell index of each point of coordinates ``X`` (0 along flat axes)."""
    lo = grid.origin @ grid.axes.T
    idx = np.zeros(X.shape, dtype=np.int64)
    for i in range(grid.dim):
        idx[:, i] = np.minimum(np.floor((X[:, i] - lo[i]) / grid.cell[i]).astype(np.int64), grid.counts[i] - 1)
    np.maximum(idx, 0, out=idx)
    return idx


def _linear(idx: np.ndarray, counts: np.ndarray) -> np.ndarray:
    return (idx[:, 0] * counts[1] + idx[:, 1]) * counts[2] + idx[:, 2]


def default_voxel(X: np.ndarray, dim: int) -> float:
    """The voxel edge making the cells of the bounding box of coordinates ``X`` (N, 3, the first
    ``dim`` not flat) about ``N / SAMPLES_PER_CELL``."""
    if dim == 0:
        return 1.0
    extent = (X.max(axis=0) - X.min(axis=0))[:dim]
    cells = max(X.shape[0] / SAMPLES_PER_CELL, 1.0)
    return float(np.prod(extent) / cells) ** (1.0 / dim)


def _enclosed_from(cell_idx: np.ndarray, first: np.ndarray, grid: _Grid) -> np.ndarray:
    """(M,) per occupied cell (``cell_idx`` (M, 3) in increasing linear order, ``first`` (M,) the
    first sample in each), the number of samples after which it and its 2 dim face neighbours
    are all occupied (int64 max: never; a cell on the grid's edge is never enclosed).

    >>> g = _Grid(np.zeros(3), np.eye(3), np.array([4, 4, 4]), np.full(3, 0.25), 3)
    >>> idx = np.array([(i, j, k) for i in range(4) for j in range(4) for k in range(4)])
    >>> e = _enclosed_from(idx, np.arange(64), g)
    >>> sorted(map(tuple, idx[e < 64].tolist()))[:2], int(np.count_nonzero(e < 64))
    ([(1, 1, 1), (1, 1, 2)], 8)
    """
    sorted_keys = _linear(cell_idx, grid.counts)
    never = np.iinfo(np.int64).max
    enclosed = first.astype(np.int64)
    for axis in range(grid.dim):
        for step in (-1, 1):
            nb = cell_idx.copy()
            nb[:, axis] += step
            inside = (nb[:, axis] >= 0) & (nb[:, axis] < grid.counts[axis])
            nkeys = _linear(np.where(inside[:, None], nb, 0), grid.counts)
            pos = np.minimum(np.searchsorted(sorted_keys, nkeys), len(sorted_keys) - 1)
            found = inside & (sorted_keys[pos] == nkeys)
            np.maximum(enclosed, np.where(found, first[pos], never), out=enclosed)
    return enclosed


def _verdict(N: int, h: float, dim: int, occupancy: tuple[int, float, float], dense: bool, half: float,
             full: float, default: float | None) -> tuple[bool, str | None]:
    """``(converged, advice)``: dense at N/2 and N and the estimates there (``half``, ``full``)
    within :data:`CONVERGED_TOLERANCE`; otherwise what to change. ``occupancy``: the cells,
    ``V(h)`` and ``V(2h)`` at N; ``default``: the default voxel for these samples (None: it is h)."""
    if dim < 2:  # a point or a curve: volume and area are 0, exactly
        return True, None
    cells, _, coarse = occupancy
    per_cell = N / max(cells, 1)
    if not dense:
        what = "volume" if dim == 3 else "area"
        # the cells at 2h are better covered than those at h: at least their measure / h^dim cells to fill
        needed = max(math.ceil(MIN_SAMPLES_PER_CELL * coarse / h**dim), 2 * N)
        larger = f"the default for these samples is {default:.3g} m" if default is not None and default > h else \
            "a larger voxel"
        return False, (f"the samples are too sparse for a {h:.3g} m voxel ({per_cell:.3g} per occupied cell; the "
                       f"extrapolation needs {MIN_SAMPLES_PER_CELL} or more at N/2 and N): the {what} is that of the "
                       f"occupied cells, below the workspace's; give fewer, larger voxels ({larger}) or more "
                       f"samples (at least about {needed:,} for this voxel)")
    change = abs(full - half) / full if full > 0 else math.inf
    if change > CONVERGED_TOLERANCE:
        return False, (f"the estimate still changes by {change:.1%} from {N // 2} to {N} samples (converged: "
                       f"within {CONVERGED_TOLERANCE:.0%}): give more samples or a larger voxel")
    return True, None


def analyse(P: np.ndarray, M: np.ndarray, *, link: str = "", measure: str = "pose", voxel: float | None = None,
            random_seed: int = 0) -> Workspace:
    """The :class:`Workspace` of sampled positions ``P`` (N, 3) and manipulability ``M`` (N,)."""
    N = P.shape[0]
    if N == 0:
        raise KinematicsError("no sample to analyse")
    if voxel is not None and not (math.isfinite(voxel) and voxel > 0):
        raise KinematicsError(f"voxel: {voxel!r}; give a positive edge in metres")
    dim, axes = _frame_of(P)
    X = _coordinates(P, axes)
    h = default_voxel(X, dim) if voxel is None else float(voxel)
    grid = _grid(X, dim, axes, h)
    idx = _cells(X, grid)
    keys = _linear(idx, grid.counts)
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    starts = np.flatnonzero(np.r_[True, sorted_keys[1:] != sorted_keys[:-1]])
    first = order[starts]  # the first sample (index) in each occupied cell
    cell_idx = idx[first]
    best = np.maximum.reduceat(M[order], starts) if N else np.empty(0)
    # the coarse cells (pairs along every axis of the same grid) and their first samples
    coarse_counts = np.maximum(grid.counts // 2, 1)
    ckeys = _linear(cell_idx // np.where(grid.counts > 1, 2, 1), coarse_counts)
    corder = np.argsort(ckeys, kind="stable")
    cstarts = np.flatnonzero(np.r_[True, ckeys[corder][1:] != ckeys[corder][:-1]])
    cfirst = np.minimum.reduceat(first[corder], cstarts)
    measure_of_cell = float(np.prod(grid.cell[:dim])) if dim else 0.0
    coarse_cell = measure_of_cell * 2**dim
    enclosed = _enclosed_from(cell_idx, first, grid)

    def occupancy(n: int) -> tuple[int, float, float]:
        """``(cells, V(h), V(2h))`` over the first n samples."""
        k = np.count_nonzero(first < n)
        return k, k * measure_of_cell, np.count_nonzero(cfirst < n) * coarse_cell

    def dense(n: int) -> bool:
        k, fine, coarse = occupancy(n)
        return n >= MIN_SAMPLES_PER_CELL * k and coarse <= MAX_COARSE_RATIO * fine

    # one estimator for the whole convergence series: the extrapolation when dense at N/2 and N
    extrapolate = bool(dim) and dense(N) and dense(max(1, N // 2))

    def estimate(n: int) -> float:
        if not dim:
            return 0.0
        _, fine, coarse = occupancy(n)
        if not extrapolate:
            return fine
        return max(2.0 * fine - coarse, np.count_nonzero(enclosed < n) * measure_of_cell)

    convergence = [(int(n), float(estimate(n))) for n in sorted({max(1, N // 4), max(1, N // 2), N})]
    curve = [(int(n), float(estimate(int(n)))) for n in sorted({int(x) for x in np.geomspace(max(1, N / 16), N, 13)})]
    value = convergence[-1][1]
    converged, advice = _verdict(N, h, dim, occupancy(N), extrapolate,
                                 convergence[-2][1] if len(convergence) > 1 else value, value,
                                 default_voxel(X, dim) if voxel is not None else None)
    centers = grid.origin + ((cell_idx + 0.5) * grid.cell) @ axes
    if dim < 3:  # flat axes: the mean position along them
        mean_flat = (P.mean(axis=0) - grid.origin) @ axes[dim:].T
        centers = centers + (mean_flat - 0.5 * grid.cell[dim:]) @ axes[dim:]
    return Workspace(
        link=link, measure=measure, points=P, manipulability=M,
        bounding_box=np.array([P.min(axis=0), P.max(axis=0)]), reach=float(np.sqrt((P * P).sum(axis=1).max())),
        dimension=dim, volume=value if dim == 3 else 0.0, area=None if dim == 3 else (value if dim == 2 else 0.0),
        voxel=h, cell=grid.cell, axes=axes, origin=grid.origin, convergence=convergence,
        voxel_index=cell_idx, voxel_centers=centers, voxel_manipulability=best, random_seed=random_seed,
        convergence_curve=curve, converged=converged, advice=advice, occupied=len(first) * measure_of_cell,
    )


def workspace(model: RobotModel, link: str, samples: int = DEFAULT_SAMPLES, *, tool: np.ndarray | None = None,
              measure: str = "pose", voxel: float | None = None, random_seed: int = 0,
              progress: Callable[[int], None] | None = None,
              keep: Callable[[np.ndarray], np.ndarray] | None = None) -> Workspace:
    """Sample the workspace of ``link`` (or of the frame ``tool`` = ``T_link_tool`` on it) and
    analyse it (see the module docstring): ``samples`` configurations, manipulability
    ``measure`` (``pose``: the 6 x k Jacobian; ``position``: its 3 position rows), grid edge
    ``voxel`` (None: chosen from the samples), draws from ``random_seed``. ``keep``: only the
    samples it accepts are analysed (:func:`sample_workspace`; the answer's ``dropped`` counts the
    others, ``collision_free`` is set)."""
    P, M = sample_workspace(model, link, samples, tool=tool, measure=measure, random_seed=random_seed,
                            progress=progress, keep=keep)
    cancel.check()
    if keep is not None and len(P) == 0:
        raise KinematicsError(f"collision_free: every one of the {samples} samples of {link!r} is in self-collision; "
                              "nothing is left to analyse")
    ws = analyse(P, M, link=link, measure=measure, voxel=voxel, random_seed=random_seed)
    if keep is None:
        return ws
    return dataclasses.replace(ws, collision_free=True, dropped=int(samples - len(P)))
