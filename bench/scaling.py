"""How the cost grows: with the batch size N (UR5, 1 to 1,000,000) and with the number of joints."""

from __future__ import annotations

import gc
import time
import tracemalloc

import numpy as np
import pinocchio as pin

from kinematics import compile_model
from kinematics.io.catalogue import default_catalogue
from kinematics.verify.pinocchio import reference_for
from kinematics.engine.plans import CHUNK_SIZE

from .common import Report, configurations, measure, table, tool_link, us

#: Batch sizes of the N sweep; the largest is FK only.
SIZES = (1, 10, 100, 1_000, 10_000, 100_000, 1_000_000)
#: Pinocchio's loop and our Jacobian are timed up to this N (bounded run time).
PIN_MAX_N = 100_000
#: Models of the dof sweep (catalogue ids; the first one found of each group).
DOF_MODELS = (("planar_2r", "double_pendulum"), ("ur5",), ("panda",), ("talos_reduced",), ("tiago_dual",))


def _peak_scratch(fn, result_bytes: int) -> tuple[float, int]:
    """(seconds, peak bytes traced by tracemalloc beyond the result itself) of one call."""
    gc.collect()
    tracemalloc.start()
    t0 = time.perf_counter()
    out = fn()
    dt = time.perf_counter() - t0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    del out
    return dt, max(0, peak - result_bytes)


def versus_n(report: Report, robot: str = "ur5", sizes=SIZES, quick: bool = False) -> list[dict]:
    model = default_catalogue().get(robot)
    poe = compile_model(model)
    ref = reference_for(model)
    pm, data = ref.pin_model, ref.pin_model.createData()
    link = tool_link(model)
    L = len(poe.link_names)
    rows, results = [], []
    for n in sizes:
        if quick and n > 100_000:
            continue
        Q = configurations(model, n)
        fns = {"fk": lambda Q=Q: poe.fk(Q)}
        if n <= PIN_MAX_N:
            X = [ref.to_pinocchio_q(q) for q in Q]

            def pin_loop(X=X):
                for x in X:
                    pin.forwardKinematics(pm, data, x)
                    pin.updateFramePlacements(pm, data)

            fns["pin"] = pin_loop
            fns["jac"] = lambda Q=Q: poe.jacobian(Q, link, "world")
        big = n >= 100_000
        t = measure(fns, rounds=(2 if n > PIN_MAX_N else 3) if big else 9, min_time=0.0 if big else 0.01)
        result_bytes = n * L * 16 * 8
        _, scratch = _peak_scratch(lambda: poe.fk(Q), result_bytes)
        results.append({"n": n, "fk": t["fk"], "pin": t.get("pin")})
        rows.append([f"{n:,}", us(t["fk"] / n), us(t["pin"] / n) if "pin" in t else "-",
                     f"{t['fk'] / t['pin']:.2f}" if "pin" in t else "-",
                     us(t["jac"] / n) if "jac" in t else "-", f"{t['fk']:.4g}",
                     f"{result_bytes / 2**20:,.1f}", f"{scratch / 2**20:,.2f}"])
    report.add(
        f"Scaling with the batch size N ({robot}, FK of all {L} links; µs per configuration)",
        table(["N", "ours FK", "Pinocchio loop", "ratio", f"ours Jacobian ({link}, world)", "ours FK total (s)",
               "result (MiB)", "peak scratch beyond the result (MiB)"], rows),
        f"The kernels work in chunks of {CHUNK_SIZE:,} configurations: the scratch memory "
        "(tracemalloc peak minus the returned array) stays bounded whatever N. "
        f"Pinocchio and our Jacobian are timed up to N = {PIN_MAX_N:,} to keep the run short.",
    )
    return results


def versus_dof(report: Report, n: int = 10_000) -> list[dict]:
    cat = default_catalogue()
    rows, results = [], []
    for group in DOF_MODELS:
        rid = next((g for g in group if g in cat), None)
        if rid is None:
            continue
        model = cat.get(rid)
        poe = compile_model(model)
        Q = configurations(model, n)
        ref = reference_for(model)
        pm, data = ref.pin_model, ref.pin_model.createData()
        X = [ref.to_pinocchio_q(q) for q in Q]

        def pin_loop(X=X):
            for x in X:
                pin.forwardKinematics(pm, data, x)
                pin.updateFramePlacements(pm, data)

        t = measure({"fk": lambda: poe.fk(Q), "pin": pin_loop}, rounds=9, min_time=0.0)
        n_moving = len(poe.joint_names)
        results.append({"robot": rid, "dof": model.dof, "fk": t["fk"], "pin": t["pin"]})
        rows.append([rid, model.dof, n_moving, len(poe.link_names), us(t["fk"] / n),
                     us(t["fk"] / n / max(1, n_moving)), us(t["fk"] / n / len(poe.link_names)),
                     us(t["pin"] / n), f"{t['fk'] / t['pin']:.2f}"])
    report.add(
        f"Scaling with the model size (FK of all links, N = {n:,}; µs per configuration)",
        table(["model", "dof", "moving joints (incl. mimic)", "links", "ours", "ours per joint", "ours per link",
               "Pinocchio loop", "ratio"], rows),
    )
    return results


def run(report: Report, quick: bool = False) -> dict:
    return {"n": versus_n(report, quick=quick), "dof": versus_dof(report, n=2_000 if quick else 10_000)}
