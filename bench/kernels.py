"""FK and Jacobian kernels against Pinocchio's Python loop, and single-configuration FK
against Pinocchio's single call and Modern Robotics' ``FKinSpace``."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from kinematics import compile_model
from kinematics.io.catalogue import default_catalogue
from kinematics.verify.pinocchio import reference_for
from kinematics.engine.buffers import aligned_empty

from .common import ROBOTS, Report, configurations, measure, table, tool_link, us

#: Targets of issue 6 (ratios ours / Pinocchio, and FKinSpace / ours).
FK_TARGET = 0.5
JACOBIAN_TARGET = 1.0
SINGLE_TARGET = 20.0
MR_TARGET = 10.0

_PIN_REFERENCE = {"world": pin.ReferenceFrame.WORLD, "local": pin.ReferenceFrame.LOCAL,
                  "local_world_aligned": pin.ReferenceFrame.LOCAL_WORLD_ALIGNED}


def _pinocchio(model, Q):
    ref = reference_for(model)
    pm = ref.pin_model
    data = pm.createData()
    X = [ref.to_pinocchio_q(q) for q in Q]
    return ref, pm, data, X


def fk_batch(report: Report, robots=ROBOTS, n: int = 10_000, rounds: int = 25) -> list[dict]:
    cat = default_catalogue()
    rows, results = [], []
    for rid in robots:
        model = cat.get(rid)
        poe = compile_model(model)
        Q = configurations(model, n)
        _, pm, data, X = _pinocchio(model, Q)
        buf = aligned_empty((n, len(poe.link_names), 4, 4))

        def pin_loop():
            for x in X:
                pin.forwardKinematics(pm, data, x)
                pin.updateFramePlacements(pm, data)

        shape = buf.shape
        t = measure({"ours": lambda: poe.fk(Q), "ours_out": lambda: poe.fk(Q, out=buf), "pin": pin_loop,
                     "fresh": lambda: np.ones(shape)}, rounds=rounds, min_time=0.0)
        ratio = t["ours"] / t["pin"]
        results.append({"robot": rid, "ratio": ratio, "ratio_out": t["ours_out"] / t["pin"],
                        "ratio_fresh": t["fresh"] / t["pin"]})
        rows.append([rid, model.dof, len(poe.link_names), pm.nframes, n, us(t["ours"] / n), us(t["ours_out"] / n),
                     us(t["pin"] / n), f"**{ratio:.2f}**", f"{t['ours_out'] / t['pin']:.2f}",
                     f"{us(t['fresh'] / n)} ({t['fresh'] / t['pin']:.2f})", "yes" if ratio <= FK_TARGET else "no"])
    report.add(
        f"FK of all links, batch of {n:,} configurations (µs per configuration)",
        table(["robot", "dof", "links", "Pinocchio frames", "N", "ours", "ours, out= buffer", "Pinocchio loop",
               "ratio", "ratio (out=)", "a new result-sized array, filled (ratio)", f"≤ {FK_TARGET}?"], rows),
        "ours: `compile_model(model).fk(Q)` (returns a new (N, L, 4, 4) array; one of 32 MiB or more "
        "reuses a buffer of an earlier result that is gone, see `kinematics/buffers.py`); *out= buffer*: "
        "the same call writing into an array the caller reuses (`fk(Q, out=buf)`). "
        "Pinocchio: `forwardKinematics` + `updateFramePlacements` looped from Python over the same "
        "configurations (already converted to Pinocchio's q), results left in `data.oMf`. The last column "
        "but one: `np.ones` of the result's shape alone (allocation, first-touch page faults and one write "
        "pass, no kinematics): what a newly mapped array of that size costs (glibc maps anything above "
        "32 MiB afresh on every call; Talos's 77 MiB result would pay it without the pool).",
    )
    return results


def jacobian_batch(report: Report, robots=ROBOTS, n: int = 10_000, rounds: int = 11) -> list[dict]:
    cat = default_catalogue()
    rows, results = [], []
    for rid in robots:
        model = cat.get(rid)
        poe = compile_model(model)
        Q = configurations(model, n)
        ref, pm, data, X = _pinocchio(model, Q)
        link = tool_link(model)
        fid = ref.frame_ids[link]
        for reference, pref in _PIN_REFERENCE.items():
            def pin_loop(pref=pref):
                for x in X:
                    pin.computeFrameJacobian(pm, data, x, fid, pref)

            t = measure({"ours": lambda reference=reference: poe.jacobian(Q, link, reference), "pin": pin_loop},
                        rounds=rounds, min_time=0.0)
            ratio = t["ours"] / t["pin"]
            results.append({"robot": rid, "reference": reference, "ratio": ratio})
            rows.append([rid, link, reference, n, us(t["ours"] / n), us(t["pin"] / n), f"**{ratio:.2f}**",
                         "yes" if ratio <= JACOBIAN_TARGET else "no"])
    report.add(
        f"Jacobian of the tool link, batch of {n:,} configurations (µs per configuration)",
        table(["robot", "link", "reference", "N", "ours", "Pinocchio loop", "ratio", f"≤ {JACOBIAN_TARGET}?"], rows),
        "ours: `jacobian(Q, link, reference)` -> (N, 6, dof); Pinocchio: `computeFrameJacobian(model, data, q, "
        "frame, reference)` looped from Python.",
    )
    return results


def _fkinspace(model, poe, q, link):
    """Modern Robotics' inputs for the tool link: M, Slist (6, k) angular first, thetalist (k,)."""
    li = int(poe.link_indices([link])[0])
    path = np.flatnonzero(poe.path_mask(li))
    theta = poe.joint_values(q[None, :])[0, path]
    return poe.M[li].copy(), poe.S[path].T.copy(), theta


def single(report: Report, robots=ROBOTS, rounds: int = 60) -> list[dict]:
    import modern_robotics as mr

    cat = default_catalogue()
    rows, results = [], []
    for rid in robots:
        model = cat.get(rid)
        poe = compile_model(model)
        Q = configurations(model, 1)
        _, pm, data, X = _pinocchio(model, Q)
        x = X[0]
        link = tool_link(model)
        M, Slist, theta = _fkinspace(model, poe, Q[0], link)
        T_mr = mr.FKinSpace(M, Slist, theta)
        T_ours = poe.fk(Q, [link])[0, 0]
        assert np.allclose(T_mr, T_ours, atol=1e-9), "FKinSpace and ours disagree"

        def pin_one():
            pin.forwardKinematics(pm, data, x)
            pin.updateFramePlacements(pm, data)

        t = measure({"ours": lambda: poe.fk(Q), "pin": pin_one, "mr": lambda: mr.FKinSpace(M, Slist, theta)},
                    rounds=rounds, min_time=0.01)
        L = len(poe.link_names)
        r_pin = t["ours"] / t["pin"]
        r_mr = t["mr"] / t["ours"]
        results.append({"robot": rid, "ratio_pin": r_pin, "mr_over_ours": r_mr})
        rows.append([rid, L, us(t["ours"]), us(t["pin"]), f"**{r_pin:.1f}**", "yes" if r_pin <= SINGLE_TARGET else "no",
                     f"{link} ({Slist.shape[1]} joints)", us(t["mr"]), f"**{r_mr:.1f}**",
                     "yes" if r_mr >= MR_TARGET else "no", f"{us(t['ours'] / L)} vs {us(t['mr'])}"])
    report.add(
        "Single configuration (µs per call)",
        table(["robot", "links", "ours: all links", "Pinocchio single call", "ours / Pinocchio",
               f"≤ {SINGLE_TARGET}?", "FKinSpace link", "FKinSpace: that link only", "FKinSpace / ours",
               f"≥ {MR_TARGET}?", "per link: ours vs FKinSpace"], rows),
        "ours: `fk(q[None])` for every link of the model; Pinocchio: `forwardKinematics` + "
        "`updateFramePlacements` (all frames); Modern Robotics: `FKinSpace(M, Slist, thetalist)` for the "
        "tool link only (one link: ours computes all the links in the time compared).",
    )
    return results


def run(report: Report, quick: bool = False) -> dict:
    n = 2_000 if quick else 10_000
    return {"fk": fk_batch(report, n=n), "jacobian": jacobian_batch(report, n=n), "single": single(report)}
