"""A 7-joint arm's self-motion against ssik in the same run
(``python -m bench.redundancy [n] [whole] [arm,arm]``).

Per arm (the Panda, the LWR, the real iiwa14 URDF of the Robotics Toolbox's data package, the xArm7;
the default parameter of each): ``n`` random configurations within the limits, their pose as the
target. ssik (the ``bench`` extra) solves the same targets: its prebuilt artifact where its geometry
is the model's (FK equal to 1e-9 on the targets' configurations), else ``Manipulator.from_axes`` of
the model's own chain (axes and points at zero, limits), so both solve one arm. Reported:

- **time per (target, value)**: ours, the slices at 16 values spread over the parameter's limits
  (``limits="respect"``, one batch); ssik, its time per pose over its 16 samples (a swivel angle or a
  locked joint, its default), and the ratio ours / ssik;
- **complete**: how often the generating configuration is listed at its own value, and how many of
  ssik's solutions (within the limits) ours lists at that solution's value of our parameter;
- **exact**: the largest pose error by Pinocchio's FK of every solution ours listed in that check,
  and of ssik's solutions (the regular ones: a double root where two branches meet converges only
  linearly and is held to the request's tolerance; counted apart);
- **intervals**: milliseconds per target of ours (every branch's in-limit ranges, ends to 1e-13)
  against ssik's sweep of 16 samples (its time per pose), on the first ``whole`` targets.

Gen3: no URDF of it is installed (example-robot-data and rtb-data ship none), so it is not here.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from kinematics import compile_model, default_catalogue
from kinematics.algorithms import ik_redundant as red
from kinematics.algorithms import ik_self_motion as sm
from kinematics.algorithms.ik import pose_errors
from kinematics.algorithms.ik_families import reduce_chain

#: (name, link, ssik's prebuilt module or None)
ARMS = (("panda", "panda_link8", "ssik.prebuilt.franka.panda_ik"), ("kuka_lwr4", "tool", None),
        ("iiwa14", "tool0", "ssik.prebuilt.kuka.iiwa14_ik"), ("xarm7", "link_eef", "ssik.prebuilt.ufactory.xarm7_ik"))
#: ssik's default samples of its redundancy parameter per pose
SSIK_SAMPLES = 16
VALUES = 16


def iiwa14_model():
    """The KUKA LBR iiwa 14 R820 of rtb-data (its shoulder axes 0.44 mm apart), or None."""
    try:
        import rtbdata
    except ImportError:
        return None
    from kinematics.io.urdf import load_urdf

    path = Path(rtbdata.__file__).parent / "xacro/kuka_description/kuka_lbr_iiwa/urdf/lbr_iiwa_14_r820.urdf"
    return load_urdf(path) if path.exists() else None


class SsikArm:
    """ssik on one of our chains: ``solve(T)`` -> (K, dof) solutions within the limits, in our frames."""

    def __init__(self, model, link, prebuilt, q_check):
        import importlib

        import ssik

        chain = reduce_chain(model, link)
        self.columns, self.dof = chain.columns, model.dof
        self.flange = np.eye(4)
        if prebuilt is not None:
            mod = importlib.import_module(prebuilt)
            ours = compile_model(model).fk(q_check, [link])[:, 0]
            theirs = np.array([mod.fk(q[chain.columns]) for q in q_check])
            if np.abs(ours - theirs).max() < 1e-9:
                self.how, self._solve = f"prebuilt {prebuilt.rsplit('.', 1)[-1]} ({mod.SOLVER_NAME})", mod.solve
                return
        P = np.vstack([chain.r[0], np.diff(chain.r, axis=0), chain.M[:3, 3] - chain.r[-1]])
        limits = np.c_[model.lower_limits[chain.columns], model.upper_limits[chain.columns]]
        arm = ssik.Manipulator.from_axes(chain.h, P, limits=limits)
        self.flange[:3, :3] = chain.M[:3, :3]  # from_axes has no rotation at home: ours = theirs · R_M
        self.how, self._solve = f"from_axes ({arm.solver_name})", arm.solve

    def solve(self, T):
        sols = self._solve(T @ np.linalg.inv(self.flange))
        out = np.zeros((len(sols), self.dof))
        for k, s in enumerate(sols):
            out[k, self.columns] = s.q
        return out


def _listed(rows, q, cols):
    return len(rows) and np.abs(np.angle(np.exp(1j * (rows[:, cols] - q[cols])))).max(axis=1).min() < 1e-6


def _pinocchio_worst(model, link, Q, T):
    from kinematics.verify.pinocchio import reference_for

    ref = reference_for(model)
    worst = 0.0
    for q, t in zip(Q, T):
        p, r = pose_errors(ref.poses(q)[link][None], t[None])
        worst = max(worst, float(p[0]), float(r[0]))
    return worst


def run(n: int = 100, whole: int = 3, arms: str = "") -> list[str]:
    """The table's rows (``arms``: comma-separated names of :data:`ARMS`, empty: all)."""
    cat = default_catalogue()
    lines = ["| arm (parameter) | ssik | ours us per (target, value) | ssik us per (target, value) | ours / ssik | "
             "generating listed | ssik solutions listed by ours | worst error ours / ssik (Pinocchio) | "
             "intervals ms per target ours / ssik 16-sample sweep |", "|" + "---|" * 9]
    for name, link, prebuilt in ARMS:
        if arms and name not in arms.split(","):
            continue
        model = iiwa14_model() if name == "iiwa14" else cat.get(name)
        if model is None:
            print(f"{name}: not installed")
            continue
        motion = red.SelfMotion(model, link)
        rng = np.random.default_rng(0)
        lo, hi = model.lower_limits, model.upper_limits
        q = lo + (hi - lo) * rng.random((n, model.dof))
        T = compile_model(model).fk(q, [link])[:, 0]
        cols = motion.chain.columns
        # ours: the slices at 16 values
        V = np.broadcast_to(np.linspace(motion.lower, motion.upper, VALUES), (n, VALUES))
        red.slices(motion, T[:2], V[:2], "respect")  # compile and warm the caches
        t = time.perf_counter()
        red.slices(motion, T, V, "respect")
        ours_pair = (time.perf_counter() - t) / V.size
        own = red.slices(motion, T, q[:, motion.column][:, None], "respect")
        generating = sum(bool(_listed(own[0][i, :own[2][i]], q[i], cols)) for i in range(n))
        # ssik on the same targets
        ssik_arm = SsikArm(model, link, prebuilt, q[:5])
        ssik_arm.solve(T[0])
        t = time.perf_counter()
        theirs = [ssik_arm.solve(T[i]) for i in range(n)]
        ssik_pose = (time.perf_counter() - t) / n
        # every ssik solution within the limits, listed by ours at its own value of our parameter
        K = max(1, max(len(s) for s in theirs))
        W = np.array([np.resize(s[:, motion.column], K) if len(s) else np.full(K, q[i, motion.column])
                      for i, s in enumerate(theirs)])
        Q, P, count, within, singular, pe, re, complete, *_ = red.slices(motion, T, W, "respect")
        inside = [s[np.all((s >= lo - 1e-9) & (s <= hi + 1e-9), axis=1)] for s in theirs]
        total = sum(len(s) for s in inside)
        missed = sum(not _listed(Q[i, :count[i]], x, cols) for i, s in enumerate(inside) for x in s)
        regular = (np.arange(Q.shape[1])[None] < count[:, None]) & ~singular
        check = min(n, 20)
        ours_worst = _pinocchio_worst(model, link, Q[:check][regular[:check]],
                                      np.repeat(T[:check], regular[:check].sum(axis=1), axis=0))
        theirs_worst = _pinocchio_worst(model, link, np.concatenate(inside[:check]),
                                        np.repeat(T[:check], [len(s) for s in inside[:check]], axis=0))
        # intervals
        t = time.perf_counter()
        sm.intervals(motion, T[:whole])
        t_int = (time.perf_counter() - t) / whole
        line = (f"| {name} ({motion.joint}) | {ssik_arm.how} | {ours_pair * 1e6:.0f} | "
                f"{ssik_pose / SSIK_SAMPLES * 1e6:.0f} | {ours_pair / (ssik_pose / SSIK_SAMPLES):.2f} | "
                f"{generating}/{n} | {total - missed}/{total} | {ours_worst:.1e} / {theirs_worst:.1e} | "
                f"{t_int * 1e3:.0f} / {ssik_pose * 1e3:.1f} |")
        print(line, f"(complete claimed {int(complete.sum())}/{n})", flush=True)
        lines.append(line)
    return lines


if __name__ == "__main__":
    args = sys.argv[1:]
    print("\n".join(run(*(int(a) for a in args[:2]), *args[2:3])))
