"""``kinematics workspace``: sample the reachable set of a link, save the cloud, plot the dexterity map.

Samples configurations uniformly within the joint limits (:func:`kinematics.usecases.workspace`),
prints the summary (bounding box, reach, volume or area and its convergence, cell size,
manipulability range), writes the cloud (``-o``: ``.npz`` with the dexterity map, or ``.csv``
rows ``x,y,z,manipulability``) and draws (``--plot``, matplotlib's Agg backend) three orthogonal
slices of the dexterity map through the root, coloured by the best manipulability per cell,
beside the convergence of the volume estimate.
"""

from __future__ import annotations

import math
import os
import sys
import time

import numpy as np

from .. import api
from ..algorithms.workspace import DEFAULT_SAMPLES, MEASURES, MIN_SAMPLES_PER_CELL, SAMPLES_PER_CELL
from ..errors import MissingExtraError
from ..usecases import Query
from . import EXIT_OK, EXIT_USAGE, add_command
from .collision import add_filter_options, filter_options
from .common import atomic_file, fail, model_or_exit_code, parse_point
from .progress import progress

OUTPUT_HELP = """output (-o, by extension):
  .npz     points (N, 3), manipulability (N,), the dexterity map voxel_centers (M, 3), voxel_index (M, 3),
           voxel_manipulability (M,) (best per cell), and bounding_box, reach, volume, area (planar),
           convergence (k, 2: samples, estimate), voxel, cell, axes, origin, dimension
  .csv     x,y,z,manipulability per sample

manipulability (--measure): the product of the singular values of the link's local_world_aligned
Jacobian over the joints on its path, 6 x k (pose, default) or its 3 position rows (position).
volume: occupied cells of edge --voxel (default: about N/%d cells in the bounding box),
extrapolated as 2 V(h) - V(2h) where the samples are dense for h (at least %d per occupied cell), else
the occupied cells' volume, flagged "not converged" with advice; its convergence is the same estimate over
the first N/4, N/2, N.""" % (SAMPLES_PER_CELL, MIN_SAMPLES_PER_CELL)


def register(sub) -> None:
    p = add_command(
        sub, "workspace", run_workspace,
        help="sample the workspace of a link: cloud, volume, reach, dexterity map and plot",
        description="Sample the reachable set of --link (or of --point on it) with N configurations drawn "
        "uniformly within the joint limits; print its bounding box, reach, volume (area for a planar arm) "
        "with the convergence over N/4, N/2, N, and the manipulability range.",
        epilog=OUTPUT_HELP + "\n\nexamples:\n"
        "  kinematics workspace --model ur5 --link tool0 -n 1000000 -o ws.npz --plot ws.png\n"
        "  kinematics workspace --model planar_2r -n 200000 --measure position --plot 2r.png\n"
        "  kinematics workspace --model panda --link panda_link8 --point 0,0,0.1 --voxel 0.05 -o tcp.csv\n",
    )
    p.add_argument("--link", metavar="NAME", help="the link (default: the model's first leaf link)")
    p.add_argument("--point", metavar="X,Y,Z", help="sample this point of the link (link frame, metres) instead of "
                   "its origin (write --point=-0.1,0,0 when the first is negative)")
    p.add_argument("-n", "--samples", type=int, default=DEFAULT_SAMPLES, metavar="N",
                   help=f"configurations to draw (default {DEFAULT_SAMPLES})")
    p.add_argument("--seed", type=int, default=0, help="random seed of the draws (default 0)")
    p.add_argument("--voxel", type=float, metavar="M", help="cell edge in metres (default: chosen from N)")
    p.add_argument("--measure", choices=tuple(MEASURES), default="pose",
                   help="manipulability of the 6 x k Jacobian (pose, default) or of its position rows")
    p.add_argument("-o", "--output", metavar="FILE", help="write the cloud: .npz or .csv")
    p.add_argument("--plot", metavar="PNG", help="draw the dexterity slices and the convergence (PNG)")
    add_filter_options(p, "--collision-free", "keep only the samples free of self-collision (joints off the link's "
                       "path at the middle of their limits); the summary says how many were dropped")


def run_workspace(args) -> int:
    model = model_or_exit_code(args, "workspace")
    if isinstance(model, int):
        return model
    if args.samples < 1:
        return fail("workspace", "--samples must be at least 1", EXIT_USAGE)
    if args.voxel is not None and not (math.isfinite(args.voxel) and args.voxel > 0):
        return fail("workspace", "--voxel must be a positive number of metres", EXIT_USAGE)
    for path, exts in ((args.output, (".npz", ".csv")), (args.plot, (".png",))):
        if path is not None and os.path.splitext(path)[1].lower() not in exts:
            return fail("workspace", f"{path}: give a file ending in {' or '.join(exts)}", EXIT_USAGE)
    try:
        point = parse_point(args.point)
    except ValueError as exc:
        return fail("workspace", str(exc), EXIT_USAGE)
    link = args.link or (model.leaf_links[0] if model.leaf_links else model.root)
    query = Query(model, link=link, point=point)
    query.frame_link()  # unknown link: exit 2 before sampling
    t0 = time.perf_counter()
    bar = progress(total=args.samples, desc="workspace", unit="sample", unit_scale=True)
    try:
        ws = api.workspace(query, samples=args.samples, voxel=args.voxel, measure=args.measure,
                           random_seed=args.seed, progress=bar.update, collision_free=args.collision_free,
                           **filter_options(args))
    finally:
        bar.close()
    elapsed = time.perf_counter() - t0
    print(summary(model.name, ws, elapsed))
    if args.output:
        write_cloud(ws, args.output)
        print(f"workspace: cloud of {ws.samples} samples -> {args.output}", file=sys.stderr)
    if args.plot:
        plot(ws, args.plot, title=f"{model.name}: {link}" + (f" + point {point}" if point else ""))
        print(f"workspace: plot -> {args.plot}", file=sys.stderr)
    return EXIT_OK


def summary(name: str, ws, elapsed: float) -> str:
    """The human summary of a workspace (several lines)."""
    lo, hi = ws.bounding_box
    what, unit = ("area", "m^2") if ws.planar else ("volume", "m^3")
    value = ws.area if ws.planar else ws.volume
    conv = ", ".join(f"{v:.4g} ({n})" for n, v in ws.convergence)
    M = ws.manipulability
    return "\n".join([
        f"workspace of {name} link {ws.link}: {ws.samples} samples (seed {ws.random_seed}) in {elapsed:.2f} s"
        + (f"; {ws.dropped} in self-collision dropped" if ws.collision_free else ""),
        f"  bounding box  min [{lo[0]:.4f}, {lo[1]:.4f}, {lo[2]:.4f}]  max [{hi[0]:.4f}, {hi[1]:.4f}, {hi[2]:.4f}] m",
        f"  reach         {ws.reach:.4f} m (from the root)",
        f"  dimension     {ws.dimension}" + (" (planar)" if ws.dimension == 2 else ""),
        f"  {what:<13} {value:.5g} {unit}; convergence (samples): {conv}"
        + ("" if ws.converged else f"\n  not converged: {ws.advice}"),
        f"  voxel         {ws.voxel:.4g} m (cells {', '.join(f'{c:.4g}' for c in ws.cell)}; "
        f"{ws.voxel_centers.shape[0]} occupied)",
        f"  manipulability ({ws.measure}) min {M.min():.4g}, mean {M.mean():.4g}, max {M.max():.4g}",
    ])


def write_cloud(ws, path: str) -> None:
    """The cloud as ``.npz`` (with the dexterity map and summary) or ``.csv``, written atomically."""
    suffix = os.path.splitext(path)[1].lower()
    with atomic_file(path, ".workspace.") as fh:
        if suffix == ".npz":
            arrays = dict(points=ws.points, manipulability=ws.manipulability, voxel_centers=ws.voxel_centers,
                          voxel_index=ws.voxel_index, voxel_manipulability=ws.voxel_manipulability,
                          bounding_box=ws.bounding_box, reach=np.float64(ws.reach), volume=np.float64(ws.volume),
                          convergence=np.array(ws.convergence, dtype=float).reshape(-1, 2),
                          voxel=np.float64(ws.voxel), cell=ws.cell, axes=ws.axes, origin=ws.origin,
                          dropped=np.int64(ws.dropped), dimension=np.int64(ws.dimension))
            if ws.planar:
                arrays["area"] = np.float64(ws.area)
            np.savez(fh, **arrays)
        else:
            fh.write(b"x,y,z,manipulability\n")
            np.savetxt(fh, np.column_stack([ws.points, ws.manipulability]), delimiter=",", fmt="%.17g")


def _slice(ws, axis: int) -> tuple[np.ndarray, list[float]] | None:
    """The dexterity map in the layer of cells that holds the root's coordinate along world ``axis``
    (best manipulability per cell, NaN where empty), with its extent for ``imshow``."""
    a, b = [i for i in range(3) if i != axis]
    counts = np.ones(3, dtype=np.int64)
    occupied = ws.voxel_index
    for i in range(3):
        if ws.cell[i] > 0:
            counts[i] = int(round((ws.bounding_box[1] @ ws.axes[i] - ws.origin @ ws.axes[i]) / ws.cell[i]))
    layer = int(math.floor((0.0 - ws.origin @ ws.axes[axis]) / ws.cell[axis])) if ws.cell[axis] > 0 else 0
    layer = min(max(layer, 0), counts[axis] - 1)
    sel = occupied[:, axis] == layer
    img = np.full((counts[b], counts[a]), np.nan)
    img[occupied[sel, b], occupied[sel, a]] = ws.voxel_manipulability[sel]
    lo = ws.origin @ ws.axes.T
    extent = [lo[a], lo[a] + counts[a] * ws.cell[a], lo[b], lo[b] + counts[b] * ws.cell[b]]
    return img, extent


def plot(ws, path: str, title: str = "") -> None:
    """Three orthogonal slices of the dexterity map through the root (planar: the plane) and the
    convergence of the volume (area) estimate, as a PNG (matplotlib, Agg backend)."""
    try:
        import matplotlib
    except ImportError as exc:
        raise MissingExtraError.of("plot", "the workspace plot (--plot)", "matplotlib") from exc

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    names = "xyz"
    world_axes = np.allclose(ws.axes, np.eye(3))
    if ws.dimension == 3 and world_axes:
        panels = [(0, "x = 0 (y-z plane)"), (1, "y = 0 (x-z plane)"), (2, "z = 0 (x-y plane)")]
    else:
        panels = [(2, "the plane of the workspace")]
    fig, axes = plt.subplots(1, len(panels) + 1, figsize=(4.6 * (len(panels) + 1), 4.4), constrained_layout=True)
    finite = ws.voxel_manipulability
    vmax = float(finite.max()) if finite.size else 1.0
    image = None
    for ax, (axis, label) in zip(axes, panels):
        img, extent = _slice(ws, axis)
        a, b = [i for i in range(3) if i != axis]
        image = ax.imshow(img, origin="lower", extent=extent, cmap="viridis", vmin=0.0, vmax=vmax,
                          interpolation="nearest")
        ax.plot([0], [0], marker="+", color="red", markersize=12, mew=2)
        ax.set_title(f"slice {label}" if ws.dimension == 3 else label, fontsize=10)
        ax.set_xlabel(f"{names[a]} [m]" if world_axes else "u [m]")
        ax.set_ylabel(f"{names[b]} [m]" if world_axes else "v [m]")
        ax.set_aspect("equal")
    if image is not None:
        fig.colorbar(image, ax=axes[: len(panels)], shrink=0.85,
                     label=f"best manipulability per cell ({ws.measure})")
    conv = axes[-1]
    curve = ws.convergence_curve or ws.convergence
    n = [c[0] for c in curve]
    v = [c[1] for c in curve]
    conv.semilogx(n, v, "o-", ms=3, color="C0", label="estimate (first n samples)")
    conv.semilogx([c[0] for c in ws.convergence], [c[1] for c in ws.convergence], "s", color="C3", ms=7,
                  label="N/4, N/2, N")
    what = "area [m²]" if ws.planar else "volume [m³]"
    conv.set_xlabel("samples")
    conv.set_ylabel(what)
    conv.set_title(f"convergence (voxel {ws.voxel:.3g} m)", fontsize=10)
    conv.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    conv.grid(True, which="both", alpha=0.3)
    conv.legend(fontsize=8, loc="lower right")
    fig.suptitle(f"{title} — {ws.samples:,} samples, reach {ws.reach:.3f} m, "
                 f"{'area' if ws.planar else 'volume'} {(ws.area if ws.planar else ws.volume):.4g}", fontsize=11)
    fig.savefig(path, dpi=110)
    plt.close(fig)
