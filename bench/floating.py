"""Floating-base models (``floating_base: true``): FK of every link and the whole-body Jacobian
of a foot or hand (6 + n columns) on the compiled floating-root engine (``compile_model``:
``engine/rooted.py``), against Pinocchio's Python loop on ``buildModelFromUrdf(...,
JointModelFreeFlyer())``, the numpy tree walk (``engine/tree.py``, what these models ran on
before) and the one-dof models' compiled kernels on the same robots (what the free-flyer root costs)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from kinematics import api, compile_model
from kinematics.engine.tree import TreeModel
from kinematics.io.catalogue import default_catalogue
from kinematics.verify.pinocchio import reference_for

from .common import Report, configurations, measure, table, tool_link, us

ROBOTS = ("solo12", "anymal_c", "go1", "talos_reduced")


def run(report: Report, quick: bool = False) -> None:
    n = 1_000 if quick else 10_000
    rounds = 3 if quick else 7
    cat = default_catalogue()
    rows = []
    for rid in ROBOTS:
        fixed = cat.get(rid)
        model = api.model_for(fixed, floating_base=True)
        ours, walk, poe = compile_model(model), TreeModel(model), compile_model(fixed)
        Q = configurations(model, n)
        Qf = np.ascontiguousarray(Q[:, 7:])
        ref = reference_for(model)
        pm, data = ref.pin_model, ref.pin_model.createData()
        X = [ref.to_pinocchio_q(q) for q in Q]
        link = tool_link(fixed)
        fid = ref.frame_ids[link]

        def pin_fk():
            for x in X:
                pin.forwardKinematics(pm, data, x)
                pin.updateFramePlacements(pm, data)

        def pin_jac():
            for x in X:
                pin.computeFrameJacobian(pm, data, x, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)

        t = measure({"fk": lambda: ours.fk(Q), "pin_fk": pin_fk, "fixed_fk": lambda: poe.fk(Qf),
                     "walk_fk": lambda: walk.fk(Q),
                     "jac": lambda: ours.jacobian(Q, link, "local_world_aligned"), "pin_jac": pin_jac,
                     "fixed_jac": lambda: poe.jacobian(Qf, link, "local_world_aligned"),
                     "walk_jac": lambda: walk.jacobian(Q, link, "local_world_aligned")},
                    rounds=rounds, min_time=0.0)
        rows.append([rid, f"{model.nq} / {model.nv}", len(model.links), link, n,
                     us(t["fk"] / n), us(t["pin_fk"] / n), f"**{t['fk'] / t['pin_fk']:.2f}**", us(t["fixed_fk"] / n),
                     f"{us(t['walk_fk'] / n)} ({t['walk_fk'] / t['fk']:.0f}x)",
                     us(t["jac"] / n), us(t["pin_jac"] / n), f"**{t['jac'] / t['pin_jac']:.2f}**",
                     us(t["fixed_jac"] / n), f"{us(t['walk_jac'] / n)} ({t['walk_jac'] / t['jac']:.0f}x)"])
    report.add(
        f"Floating base (free-flyer root), batch of {n:,} configurations (µs per configuration)",
        table(["robot", "nq / nv", "links", "Jacobian link", "N", "FK ours", "FK Pinocchio loop", "FK ratio",
               "FK fixed base (compiled)", "FK tree walk (slower by)", "J ours", "J Pinocchio loop", "J ratio",
               "J fixed base (compiled)", "J tree walk (slower by)"], rows),
        "ours: `compile_model(model).fk(Q)` / `.jacobian(Q, link, 'local_world_aligned')` of the model with "
        "`floating_base: true` (the compiled floating-root engine, `kinematics/engine/rooted.py`); *tree walk*: the "
        "numpy engine `kinematics/engine/tree.py` (`TreeModel`) on the same model, which these models ran on before; "
        "Pinocchio: "
        "`forwardKinematics` + `updateFramePlacements`, and `computeFrameJacobian`, looped from Python over "
        "the same configurations; *fixed base*: the same robot without the free flyer on the compiled kernels.",
    )
