"""``kinematics check``: parity of every catalogue model with Pinocchio."""

from __future__ import annotations

import sys
import time

from ..io.catalogue import default_catalogue
from ..io.floating import with_floating_base
from ..tolerances import AGREEMENT_TOLERANCE
from . import add_command
from .progress import progress


def register(sub) -> None:
    p = add_command(
        sub, "check", run, model=False,
        help="compare FK, Jacobians and velocities with Pinocchio on the catalogue",
        description="For every catalogue model (or those named), compare FK of every link, the three "
        "Jacobians of every leaf link and the velocity of every link (three references, random joint "
        "velocities) with Pinocchio at random configurations. Exit 1 on any disagreement.",
    )
    p.add_argument("--samples", type=int, default=5, help="configurations per model (default 5)")
    p.add_argument("--model", action="append", metavar="ID", help="check only this model (repeatable)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--tolerance", type=float, default=AGREEMENT_TOLERANCE, help="largest allowed deviation (default 1e-9)")
    p.add_argument("--floating-base", action="store_true",
                   help="check each model on a free-flyer root joint (against Pinocchio's JointModelFreeFlyer root)")


def run(args) -> int:
    from ..verify.parity import check_model, summary_line  # Pinocchio: the `verify` extra

    cat = default_catalogue()
    ids = args.model or cat.ids()
    for mid in ids:
        cat.entry(mid)  # unknown ids fail before any work
    t0 = time.perf_counter()
    results = []
    for mid in progress(ids, desc="check", unit="model"):
        if getattr(args, "floating_base", False):
            load = lambda mid=mid: with_floating_base(cat.get(mid))  # noqa: E731
        else:
            load = lambda mid=mid: cat.get(mid)  # noqa: E731
        results.append(check_model(mid, load, args.samples, args.seed, args.tolerance))
    elapsed = time.perf_counter() - t0
    w = max(len(r.model_id) for r in results)
    print(f"{'model':<{w}}  {'dof':>4}  {'links':>5}  {'position':>9}  {'rotation':>9}  {'jacobian':>9}  "
          f"{'velocity':>9}  status")
    for r in results:
        if r.status == "refused":
            print(f"{r.model_id:<{w}}  {'-':>4}  {'-':>5}  {'-':>9}  {'-':>9}  {'-':>9}  {'-':>9}  refused: {r.message}")
        else:
            print(
                f"{r.model_id:<{w}}  {r.dof:>4}  {r.links:>5}  {r.position_error:>9.2e}  "
                f"{r.rotation_error:>9.2e}  {r.jacobian_error:>9.2e}  {r.velocity_error:>9.2e}  {r.status}"
            )
    print(f"{len(results)} models, {args.samples} configurations each, {elapsed:.1f} s", file=sys.stderr)
    print(summary_line(results, args.tolerance))
    return 1 if any(r.status == "FAIL" for r in results) else 0
