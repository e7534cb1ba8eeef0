"""``kinematics calibrate`` and ``kinematics calibration-poses``: kinematic calibration from a CSV.

``calibrate`` reads the measurements (CSV: joint columns by name, then ``x,y,z`` or
``x,y,z,qw,qx,qy,qz``, in the measuring device's frame), fits the model
(:func:`kinematics.usecases.calibrate`), prints a table of the parameters with their standard
deviations, the unidentifiable ones with the reason, and a residual summary; writes the
calibrated URDF (``-o``) and, with ``--plot``, a PNG of the residual of every measurement before
and after (matplotlib, Agg backend). ``calibration-poses`` prints (or writes as CSV) ``n``
configurations where measuring determines the parameters best.
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np

from .. import usecases
from ..usecases import Query
from ..io.pose_records import pose_record
from ..spatial.transforms import pose_components
from . import EXIT_OK, EXIT_USAGE, add_command
from .common import atomic_file, fail, model_or_exit_code, parse_point


def register(sub) -> None:
    p = add_command(
        sub, "calibrate", run_calibrate,
        help="calibrate a model from measured marker positions or tool poses (CSV) -> URDF",
        description="Fit every joint origin and zero on the path to --link, the measuring device's frame and the "
        "marker point (or tool frame) to measurements, and write the calibrated URDF.",
        epilog="measurements CSV: a header naming every joint, then x,y,z (positions) or x,y,z,qw,qx,qy,qz (poses)\n\n"
        "examples:\n"
        "  kinematics calibrate --model ur5 --link tool0 measurements.csv -o ur5_calibrated.urdf\n"
        "  kinematics calibrate --model ur5 --link tool0 m.csv --loss huber --holdout 0.3 --plot residuals.png\n")
    p.add_argument("measurements", metavar="CSV", help="the measurements ('-' reads stdin)")
    p.add_argument("--link", required=True, metavar="NAME", help="the link the marker or tool is fixed to")
    p.add_argument("--point", metavar="X,Y,Z", help="a guess of the marker point on the link (metres)")
    p.add_argument("--parameters", choices=("full", "joint_offsets"), default="full")
    p.add_argument("--base", choices=("estimate", "fixed"), default="estimate",
                   help="estimate the device frame (default) or take it as the root frame")
    p.add_argument("--tool", choices=("estimate", "fixed"), default="estimate")
    p.add_argument("--loss", choices=("linear", "huber"), default="linear")
    p.add_argument("--holdout", type=float, default=0.0, metavar="F", help="fraction kept out of the fit")
    p.add_argument("--seed", type=int, default=0, help="which measurements are held out (default 0)")
    p.add_argument("--rotation-weight", type=float, default=1.0, metavar="M",
                   help="metres per radian of a rotation residual (poses; default 1)")
    p.add_argument("--name", help="the calibrated robot's name")
    p.add_argument("--compliance", nargs="?", const="all", metavar="JOINT,...",
                   help="also estimate joint compliance under gravity (c times the torque a joint holds, from the "
                   "URDF's masses): every joint on the path, or those named")
    p.add_argument("--prior", action="store_true",
                   help="maximum a posteriori: joint origins within 1 cm and 20 mrad, zeros within 20 mrad, "
                   "compliances within 5 mrad/(N m) (one standard deviation)")
    p.add_argument("-o", "--output", metavar="URDF", help="write the calibrated URDF")
    p.add_argument("--json", metavar="FILE", help="write the result (base, point/tool, parameters, residuals) as JSON")
    p.add_argument("--plot", metavar="PNG", help="draw the residual of every measurement before and after")

    q = add_command(
        sub, "calibration-poses", run_poses, help="choose the configurations to measure for a calibration (D-optimal)",
        description="Choose N configurations within the limits where measuring --link determines the calibration "
        "parameters best (D-optimality of the identification Jacobian, greedy then exchange).")
    q.add_argument("--link", required=True, metavar="NAME")
    q.add_argument("-n", type=int, default=30, metavar="N", help="how many configurations (default 30)")
    q.add_argument("--measure", choices=("position", "pose"), default="position")
    q.add_argument("--point", metavar="X,Y,Z", help="where the marker will be on the link (default 0.05,0.05,0.05)")
    q.add_argument("--seed", type=int, default=0)
    q.add_argument("-o", "--output", metavar="CSV", help="write the configurations as CSV (joint columns)")


def _query(args, command: str) -> Query | int:
    """The query of ``--link`` and ``--point`` on the model the options name, or the exit code of a
    model or a point that cannot be read, after saying why."""
    model = model_or_exit_code(args, command)
    if isinstance(model, int):
        return model
    try:
        point = parse_point(args.point)
    except ValueError as exc:
        return fail(command, str(exc), EXIT_USAGE)
    return Query(model, link=args.link, point=point)


def run_calibrate(args) -> int:
    query = _query(args, "calibrate")
    if isinstance(query, int):
        return query
    model = query.model
    for path, ext in ((args.output, ".urdf"), (args.plot, ".png")):
        if path is not None and os.path.splitext(path)[1].lower() != ext:
            return fail("calibrate", f"{path}: give a file ending in {ext}", EXIT_USAGE)
    try:
        text = sys.stdin.read() if args.measurements == "-" else open(args.measurements, "rb").read()
    except OSError as exc:
        return fail("calibrate", f"{args.measurements}: {exc.strerror}", EXIT_USAGE)
    fit = {"parameters": args.parameters, "base": args.base, "tool": args.tool, "loss": args.loss,
           "holdout": args.holdout, "random_seed": args.seed, "rotation_weight": args.rotation_weight,
           "compliance": _compliance(args.compliance), "prior": args.prior}  # the use case builds FitOptions once
    cal = usecases.calibrate(query, csv=text, name=args.name, **fit)
    print(report(cal, model.name))
    if args.output:
        _write(args.output, cal.urdf.encode("utf-8"))
        print(f"calibrate: calibrated URDF -> {args.output}", file=sys.stderr)
    if args.json:
        _write(args.json, json.dumps(as_dict(cal), indent=1).encode())
        print(f"calibrate: result -> {args.json}", file=sys.stderr)
    if args.plot:
        plot(cal, args.plot, f"{model.name}: {args.link}")
        print(f"calibrate: plot -> {args.plot}", file=sys.stderr)
    return EXIT_OK


def as_dict(cal) -> dict:
    """The result in the service's field names (``base`` and ``point`` / ``tool`` as FK accepts them)."""
    return {
        "from": cal.source, "link": cal.link, "measure": cal.measure, "base": pose_record(cal.base),
        "point": None if cal.point is None else [float(v) for v in cal.point],
        "tool": None if cal.tool is None else pose_record(cal.tool), "identifiable": cal.identifiable,
        "parameters": cal.parameters, "unidentifiable": cal.unidentifiable, "condition_number": cal.condition_number,
        "rmse_before": cal.rmse_before, "rmse_after": cal.rmse_after, "max_before": cal.max_before, "max_after": cal.max_after,
        "outliers": cal.outliers, "holdout": cal.holdout, "holdout_rmse": cal.holdout_rmse,
        "residuals": {"before": cal.residuals_before.tolist(), "after": cal.residuals_after.tolist()},
    }


def report(cal, name: str) -> str:
    """The parameter table and the residual summary (several lines)."""
    lines = [f"calibration of {name} link {cal.link} from {len(cal.residuals_after)} measured {cal.measure}s: "
             f"{cal.identifiable} identifiable combinations, condition number {cal.condition_number:.3g}",
             f"  {'parameter':<34} {'value':>14} {'sigma':>12}"]
    units = {q.name: "mrad/Nm" if q.component == "compliance" else "mrad" if q.angular else "mm"
             for q in cal.error_model.parameters}
    for p in cal.parameters:
        unit = units[p["name"]]  # every unit scaled by 1e3
        lines.append(f"  {p['name']:<34} {p['value'] * 1e3:>11.4f} {unit:<4} {p['sigma'] * 1e3:>8.4f} {unit}")
    lines.append(f"  unidentifiable: {len(cal.unidentifiable)}")
    for u in cal.unidentifiable:
        lines.append(f"    {u['name']:<32} {u['reason']}")
    b, p = cal.base[:3, 3], pose_components(cal.base)["quaternion"]
    lines.append(f"  base (T_device_root): position [{b[0]:.6f}, {b[1]:.6f}, {b[2]:.6f}] m, "
                 f"quaternion wxyz [{', '.join(f'{v:.6f}' for v in p)}]")
    if cal.point is not None:
        lines.append(f"  point on {cal.link}: [{', '.join(f'{v:.6f}' for v in cal.point)}] m")
    else:
        t, q = cal.tool[:3, 3], pose_components(cal.tool)["quaternion"]
        lines.append(f"  tool on {cal.link}: position [{', '.join(f'{v:.6f}' for v in t)}] m, "
                     f"quaternion wxyz [{', '.join(f'{v:.6f}' for v in q)}]")
    lines.append(f"  residuals (m): RMS before {cal.rmse_before:.3e}, after {cal.rmse_after:.3e}, "
                 f"largest before {cal.max_before:.3e}, after {cal.max_after:.3e}")
    if cal.holdout:
        held = "n/a" if cal.holdout_rmse is None else f"{cal.holdout_rmse:.3e}"
        lines.append(f"  held out: {len(cal.holdout)} measurements, RMS {held} m")
    lines.append(f"  outliers: {', '.join(map(str, cal.outliers)) if cal.outliers else 'none'}")
    return "\n".join(lines)


def plot(cal, path: str, title: str = "") -> None:
    """The Euclidean residual of every measurement before and after (log scale), held-out and
    outlier measurements marked, as a PNG (matplotlib, Agg backend)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(cal.residuals_after)
    idx = np.arange(n)
    fig, ax = plt.subplots(figsize=(max(6.0, min(16.0, n * 0.12)), 4.0), constrained_layout=True)
    ax.bar(idx, cal.residuals_before * 1e3, color="#d9a0a0", label=f"before (RMS {cal.rmse_before * 1e3:.3f} mm)")
    ax.bar(idx, cal.residuals_after * 1e3, color="#3070b0", label=f"after (RMS {cal.rmse_after * 1e3:.4f} mm)")
    if cal.holdout:
        ax.scatter(cal.holdout, cal.residuals_after[cal.holdout] * 1e3, marker="o", facecolors="none",
                   edgecolors="black", s=18, label="held out", zorder=3)
    if cal.outliers:
        ax.scatter(cal.outliers, cal.residuals_after[cal.outliers] * 1e3, marker="x", color="red", s=30,
                   label="outlier", zorder=4)
    ax.set_yscale("log")
    ax.set_xlabel("measurement")
    ax.set_ylabel("position residual [mm]")
    ax.set_title(title)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _write(path: str, data: bytes) -> None:
    with atomic_file(path, ".calibrate.") as fh:
        fh.write(data)


def run_poses(args) -> int:
    query = _query(args, "calibration-poses")
    if isinstance(query, int):
        return query
    model = query.model
    choice = usecases.calibration_poses(query, args.n, measure=args.measure,
                                        random_seed=args.seed)
    header = ",".join(model.joint_names)
    rows = "\n".join(",".join(repr(float(v)) for v in q) for q in choice.q)
    print(f"# {args.n} configurations for {model.name} link {args.link} ({args.measure}s): D-optimal log det "
          f"{choice.log_det:.2f} (random {choice.random_log_det:.2f}), condition number {choice.condition_number:.3g} "
          f"(random {choice.random_condition_number:.3g}), {choice.identifiable} identifiable", file=sys.stderr)
    if args.output:
        _write(args.output, (header + "\n" + rows + "\n").encode())
        print(f"calibration-poses: -> {args.output}", file=sys.stderr)
    else:
        print(header)
        print(rows)
    return EXIT_OK


def _compliance(value: str | None):
    """``--compliance`` as the use case takes it: None, True (every path joint) or the joints named."""
    if value is None:
        return None
    return True if value == "all" else {"joints": [j for j in value.split(",") if j]}
