"""Inverse kinematics: success rate and time per solve, ours against two baselines.

    python -m bench.run_all --only ik [--quick] [--output bench/RESULTS.md]
        (the table; with --output it is written to bench/RESULTS_IK.md, beside the other suites')
    python -m bench.ik [--n 1000] [--robots ur5,panda] [--max-iterations 100] [--restarts 50]

Protocol: for each robot, N configurations uniform within the limits (continuous joints in
+-2 pi), the link's pose in each (Pinocchio's FK) as the target, no seed given. Every solver's
answer goes through the same test, :func:`check`: Pinocchio's FK of the answer within 1e-6 m
and 1e-6 rad (angle of ``R_target^T R`` by atan2) of the target, and every joint value within
the model's limits (1e-12 slack; continuous joints unlimited).

Solvers, on the same targets and joint limits on:

- ours: ``kinematics.algorithms.ik.inverse_kinematics`` (defaults: 100 steps per attempt,
  50 restarts), timed per target (one call per target, Python overhead included) and as one
  batch call over all N targets (time / N).
- the Robotics Toolbox's C++ ``ik_LM`` (``roboticstoolbox-python``), built from the same URDF
  text (visuals and collisions dropped), called once per target through ``ETS.ik_LM`` of the
  link's precomputed ETS (no Python kinematics in the loop), random starts (``q0=None``).
- pytorch-kinematics' ``PseudoInverseIK`` on the CPU in float64 (one torch thread, like ours),
  batched over all N targets with its random retries; time per solve = batch time / N.

A baseline that is not installed is reported as such (``pip install -e '.[ik-baselines]'``).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import xml.etree.ElementTree as ET

import numpy as np

from .common import SEED, Report, table, us

#: clock of this suite: wall time, as in the issue's protocol (the in-process CPU-time clock of
#: the other suites does not filter a shared VM's stolen time either); the solvers are
#: interleaved target by target instead, so that a slow minute falls on all of them
CLOCK = time.perf_counter
CLOCK_NAME = "wall time (time.perf_counter)"
#: (catalogue id, link) of the IK table
IK_ROBOTS = (("ur5", "tool0"), ("panda", "panda_link8"), ("xarm7", "link_eef"),
             ("kinova", "j2s6s200_end_effector"), ("kuka_lwr4", "tool"))
#: the success test, for every solver
POSITION_TOLERANCE = 1e-6
ROTATION_TOLERANCE = 1e-6
LIMIT_SLACK = 1e-12
#: ik_LM: steps per search and searches (our budget: 100 steps x (1 + 50 restarts)); its
#: tolerance is on E = 1/2 |e|^2 (e = position error and rotation vector): E <= 5e-13 alone would
#: already bound both errors by 1e-6, 1e-13 leaves a margin (|e| <= 4.5e-7)
RTB_ILIMIT = 100
RTB_SLIMIT = 51
RTB_TOL = 1e-13
#: PseudoInverseIK: iterations and retries (run side by side per target, batched)
PTK_MAX_ITERATIONS = 100
PTK_RETRIES = 50
#: solver names as the tables print them
DISPLAY = {"ptk": "pytorch-kinematics"}


# --------------------------------------------------------------------------- the common test

def rotation_angles(R_target: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Angle (N,) of ``R_target^T R`` by atan2 (accurate near 0 and pi)."""
    D = np.swapaxes(R_target, 1, 2) @ R
    v = np.stack([D[:, 2, 1] - D[:, 1, 2], D[:, 0, 2] - D[:, 2, 0], D[:, 1, 0] - D[:, 0, 1]], axis=1)
    return np.arctan2(0.5 * np.linalg.norm(v, axis=1), 0.5 * (np.trace(D, axis1=1, axis2=2) - 1.0))


def pinocchio_poses(model, link: str, Q: np.ndarray) -> np.ndarray:
    from kinematics.verify.pinocchio import reference_for

    ref = reference_for(model)
    return np.stack([ref.poses(q)[link] for q in Q])


def check(model, link: str, Q: np.ndarray, targets: np.ndarray) -> dict[str, np.ndarray]:
    """The one success test: Pinocchio's FK of ``Q`` vs ``targets``, and the limits."""
    Q = np.asarray(Q, dtype=float)
    finite = np.isfinite(Q).all(axis=1)
    T = pinocchio_poses(model, link, np.where(np.isfinite(Q), Q, 0.0))
    position = np.where(finite, np.linalg.norm(T[:, :3, 3] - targets[:, :3, 3], axis=1), np.inf)
    rotation = np.where(finite, rotation_angles(targets[:, :3, :3], T[:, :3, :3]), np.inf)
    within = finite & ((Q >= model.lower_limits - LIMIT_SLACK) & (Q <= model.upper_limits + LIMIT_SLACK)).all(axis=1)
    ok = (position <= POSITION_TOLERANCE) & (rotation <= ROTATION_TOLERANCE) & within
    return {"success": ok, "position": position, "rotation": rotation, "within": within}


def problem(model, link: str, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` configurations uniform within the limits and their link poses (the targets)."""
    import zlib

    Q = model.sample_configurations(n, np.random.default_rng([SEED, zlib.crc32(model.name.encode())]))
    return Q, pinocchio_poses(model, link, Q)


def kinematic_urdf(text: str) -> str:
    """The URDF without visuals, collisions, inertias, dynamics, transmissions (kinematics only:
    mesh paths of ``package://`` would need ROS packages the baselines cannot resolve)."""
    root = ET.fromstring(text.encode())
    for element in root.iter():
        for tag in ("visual", "collision", "inertial", "dynamics", "safety_controller", "calibration"):
            for child in element.findall(tag):
                element.remove(child)
    for tag in ("transmission", "gazebo", "material"):
        for child in root.findall(tag):
            root.remove(child)
    return ET.tostring(root, encoding="unicode")


def default_seed(model) -> np.ndarray:
    """The values of joints a baseline does not move (off the link's path): the middle of the
    limits, as ours does."""
    from kinematics.algorithms.ik import middle_of_limits

    return middle_of_limits(model)


# --------------------------------------------------------------------------- the solvers

class Ours:
    """``inverse_kinematics`` on one target per call, or on all of them in one call."""

    name = "ours"

    def __init__(self, model, link: str, max_iterations: int | None = None, restarts: int | None = None):
        from kinematics.algorithms import ik

        self.ik, self.model, self.link = ik, model, link
        self.settings = {"max_iterations": max_iterations or ik.DEFAULT_MAX_ITERATIONS,
                         "restarts": ik.DEFAULT_RESTARTS if restarts is None else restarts}

    def warm_up(self, targets: np.ndarray) -> None:  # compile / load the kernels, build the model
        self.ik.inverse_kinematics(self.model, self.link, targets[:4], **self.settings)

    def single(self, target: np.ndarray) -> tuple[np.ndarray, bool, int]:
        sol = self.ik.inverse_kinematics(self.model, self.link, target[None], **self.settings)
        return sol.q[0], bool(sol.success[0]), int(sol.iterations[0])

    def batch(self, targets: np.ndarray):
        return self.ik.inverse_kinematics(self.model, self.link, targets, **self.settings)


class IkLM:
    """The Robotics Toolbox's C++ ``ik_LM`` on the link's ETS, built from the same URDF."""

    name = "ik_LM"

    def __init__(self, model, link: str):
        import roboticstoolbox as rtb
        from roboticstoolbox.models.URDF.URDFRobot import URDF_file

        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, f"{model.name}.urdf")
            with open(path, "w") as f:
                f.write(kinematic_urdf(model.urdf))
            elinks, name, _ = URDF_file(path)
        robot = rtb.Robot(elinks, name=name)
        self.ets = robot.ets(end=link)
        # ik_LM's q (ets.n,) is in the order of the ETS's joints: map it to ours by joint name
        by_jindex = {l.jindex: l._joint_name for l in robot.links if l.isjoint}
        self.columns = [model.q_index[by_jindex[e.jindex]] for e in self.ets if e.isjoint]
        self.seed = default_seed(model)
        self.settings = {"ilimit": RTB_ILIMIT, "slimit": RTB_SLIMIT, "tol": RTB_TOL, "joint_limits": True}
        self.version = rtb.__version__

    def warm_up(self, targets: np.ndarray) -> None:
        for T in targets[:10]:
            self.ets.ik_LM(T, **self.settings)

    def single(self, target: np.ndarray) -> tuple[np.ndarray, bool, int]:
        sol = self.ets.ik_LM(target, **self.settings)
        q = self.seed.copy()
        q[self.columns] = sol.q
        return q, bool(sol.success), int(sol.iterations)


def solve_single(model, solvers: list, targets: np.ndarray) -> dict[str, dict]:
    """Each solver once per target, the solvers interleaved target by target (so that a slow
    minute of the shared machine falls on all of them); seconds by :data:`CLOCK`."""
    N = len(targets)
    out = {s.name: {"q": np.empty((N, model.dof)), "own_success": np.zeros(N, dtype=bool),
                    "iterations": np.zeros(N, dtype=np.int64), "times": np.empty(N)} for s in solvers}
    for s in solvers:
        s.warm_up(targets)
    for i in range(N):
        order = solvers if i % 2 == 0 else solvers[::-1]
        for s in order:
            r = out[s.name]
            t0 = CLOCK()
            q, ok, steps = s.single(targets[i])
            r["times"][i] = CLOCK() - t0
            r["q"][i], r["own_success"][i], r["iterations"][i] = q, ok, steps
    for r in out.values():
        r["single_us"] = float(np.median(r["times"])) * 1e6
        r["single_mean_us"] = float(np.mean(r["times"])) * 1e6
    return out


def solve_ours_batch(ours: Ours, targets: np.ndarray) -> dict:
    t0 = CLOCK()
    sol = ours.batch(targets)
    return {"batch_us": (CLOCK() - t0) / len(targets) * 1e6, "q": sol.q}


def solve_ptk(model, link: str, targets: np.ndarray) -> dict:
    import logging
    from importlib.metadata import version

    import pytorch_kinematics as pk
    import torch

    logging.getLogger("pytorch_kinematics").setLevel(logging.ERROR)
    torch.set_num_threads(1)
    torch.manual_seed(SEED)
    chain = pk.build_serial_chain_from_urdf(kinematic_urdf(model.urdf).encode(), link)
    chain = chain.to(dtype=torch.float64, device="cpu")
    names = chain.get_joint_parameter_names(exclude_fixed=True)
    columns = [model.q_index[n] for n in names]
    limits = torch.stack([chain.low, chain.high], dim=1)

    def solver():
        return pk.PseudoInverseIK(chain, max_iterations=PTK_MAX_ITERATIONS, num_retries=PTK_RETRIES,
                                  joint_limits=limits, early_stopping_any_converged=True,
                                  pos_tolerance=POSITION_TOLERANCE, rot_tolerance=ROTATION_TOLERANCE)

    goal = pk.Transform3d(matrix=torch.as_tensor(targets, dtype=torch.float64))
    solver().solve(pk.Transform3d(matrix=torch.as_tensor(targets[:4], dtype=torch.float64)))  # warm-up
    ik = solver()
    t0 = CLOCK()
    sol = ik.solve(goal)
    elapsed = CLOCK() - t0
    # per target: its first converged retry, else the retry of smallest error
    conv = sol.converged.numpy()
    err = (sol.err_pos + sol.err_rot).numpy()
    pick = np.where(conv.any(axis=1), conv.argmax(axis=1), err.argmin(axis=1))
    q = sol.solutions.numpy()[np.arange(len(targets)), pick]
    N = len(targets)
    Q = np.tile(default_seed(model), (N, 1))
    Q[:, columns] = q
    return {"q": Q, "batch_us": elapsed / N * 1e6, "own_success": conv.any(axis=1),
            "version": version("pytorch-kinematics"), "torch": torch.__version__}


def _error(exc: Exception) -> str:
    if isinstance(exc, ImportError):
        return f"not installed ({exc}; `pip install -e '.[ik-baselines]'`)"
    return f"{type(exc).__name__}: {exc}"


def _try(fn, *args, **kw) -> dict:
    try:
        return fn(*args, **kw)
    except Exception as exc:  # noqa: BLE001 - a baseline that fails is reported, the others go on
        return {"error": _error(exc)}


# --------------------------------------------------------------------------- the table

def pct(x: np.ndarray) -> str:
    return f"{100.0 * float(np.mean(x)):.1f}"


def failures(model, link, name: str, res: dict, targets: np.ndarray) -> str | None:
    """One line on the answers that failed the test: which part failed, their errors."""
    c = res["check"]
    bad = ~c["success"]
    if not bad.any():
        return None
    pos = c["position"][bad]
    rot = c["rotation"][bad]
    parts = [f"{model.name}, {DISPLAY.get(name, name)}: {int(bad.sum())} of {len(bad)} failed"]
    parts.append(f"position > tol {int((pos > POSITION_TOLERANCE).sum())}, rotation > tol "
                 f"{int((rot > ROTATION_TOLERANCE).sum())}, outside limits {int((~c['within'][bad]).sum())}")
    parts.append(f"median errors {np.median(pos):.2g} m / {np.median(rot):.2g} rad")
    if "own_success" in res:
        parts.append(f"solver's own flag true on {int(res['own_success'][bad].sum())} of them")
    if "iterations" in res:
        parts.append(f"median steps {int(np.median(res['iterations'][bad]))}")
    return "; ".join(parts)


def run(report: Report, quick: bool = False, n: int | None = None, robots=None,
        max_iterations: int | None = None, restarts: int | None = None, baselines: bool = True) -> list[dict]:
    from kinematics import default_catalogue
    from kinematics.algorithms import ik

    N = n or (100 if quick else 1000)
    catalogue = default_catalogue()
    rows, notes, steps, out = [], [], [], []
    versions: dict[str, str] = {}
    errors: dict[str, str] = {}
    for rid, link in IK_ROBOTS:
        if robots and rid not in robots:
            continue
        model = catalogue.get(rid)
        _, targets = problem(model, link, N)
        ours = Ours(model, link, max_iterations, restarts)
        singles = [ours]
        if baselines:
            try:
                singles.append(IkLM(model, link))
            except Exception as exc:  # noqa: BLE001 - a baseline that fails is reported, the others go on
                errors["ik_LM"] = _error(exc)
        res = solve_single(model, singles, targets)
        batch = solve_ours_batch(ours, targets)
        res["ours"]["batch_us"] = batch["batch_us"]
        res["ours"]["settings"] = ours.settings
        batch_same = bool(np.array_equal(batch["q"], res["ours"]["q"]))
        if len(singles) > 1:
            versions["ik_LM"] = singles[1].version
        if baselines:
            res["ptk"] = _try(solve_ptk, model, link, targets)
            if "error" in res["ptk"]:
                errors["ptk"] = res.pop("ptk")["error"]
            else:
                versions["ptk"] = f"{res['ptk']['version']}, torch {res['ptk']['torch']}"
        for name, r in res.items():
            r["check"] = check(model, link, r["q"], targets)
            line = failures(model, link, name, r, targets)
            if line:
                notes.append(line)

        def rate(name):
            r = res.get(name)
            return "n/a" if r is None else pct(r["check"]["success"])

        def t(name, key, mean_key=None):
            r = res.get(name)
            if r is None or key not in r:
                return "n/a"
            return us(r[key] * 1e-6) + (f" ({us(r[mean_key] * 1e-6)})" if mean_key else "")

        o = res["ours"]
        rtb_us = res.get("ik_LM", {}).get("single_us")
        rates = {k: float(np.mean(v["check"]["success"])) for k, v in res.items()}
        best_baseline = max((v for k, v in rates.items() if k != "ours"), default=0.0)
        met = (rates["ours"] >= 0.999 and rates["ours"] >= best_baseline
               and (rtb_us is None or o["single_us"] <= rtb_us))
        rows.append([rid, link, model.dof, N, f"**{rate('ours')}**", rate("ik_LM"), rate("ptk"),
                     f"**{us(o['single_us'] * 1e-6)}** ({us(o['single_mean_us'] * 1e-6)})",
                     us(o["batch_us"] * 1e-6), t("ik_LM", "single_us", "single_mean_us"),
                     t("ptk", "batch_us"), f"**{o['single_us'] / rtb_us:.2f}**" if rtb_us else "n/a",
                     ("yes" if met else "**no**") if rtb_us is not None or not met else "n/a (no ik_LM)"])
        steps.append(f"{rid}: ours {np.median(o['iterations']):.0f} / {np.mean(o['iterations']):.1f} / "
                     f"{np.max(o['iterations'])}" + (
                         f", ik_LM {np.median(res['ik_LM']['iterations']):.0f} / "
                         f"{np.mean(res['ik_LM']['iterations']):.1f} / {np.max(res['ik_LM']['iterations'])}"
                         if "ik_LM" in res else ""))
        if not batch_same:
            notes.append(f"{rid}: the batch call's answers differ from the single calls' (the table's "
                         f"success is the single calls')")
        out.append({"robot": rid, "link": link, "results": res})
    settings = out[0]["results"]["ours"]["settings"] if out else {}
    headers = ["robot", "link", "dof", "N", "success % ours", "ik_LM", "pytorch-kinematics",
               "µs/solve ours, single: median (mean)", "ours, batch / N", "ik_LM, single: median (mean)",
               "pytorch-kinematics, batch / N",
               "ours single / ik_LM (medians)", "targets met?"]
    note = "\n".join([
        f"Same targets for every solver: N configurations uniform within the limits (continuous joints in "
        f"±2π), the link's pose in each (Pinocchio's FK) as the target, no seed. **Success**, one test for "
        f"every solver: Pinocchio's FK of the answer within {POSITION_TOLERANCE:g} m and "
        f"{ROTATION_TOLERANCE:g} rad (atan2 angle of R_targetᵀR) of the target, and every joint within the "
        f"model's limits (±{LIMIT_SLACK:g}; continuous joints unlimited). **Times**: {CLOCK_NAME}; single "
        f"calls are interleaved target by target (ours, ik_LM, then ik_LM, ours, ...), median and "
        f"(mean) over the N targets; a batch is one call over all N targets, divided by N (a mean: the "
        f"few targets that need many restarts weigh in it, not in the medians). Settings:",
        "",
        f"- **ours**: `inverse_kinematics(model, link, targets)`, max_iterations="
        f"{settings.get('max_iterations')}, restarts={settings.get('restarts')} (DAMPING={ik.DAMPING:g}, "
        f"POLISH={ik.POLISH:g}); single = one call per target (Python overhead included), batch = one "
        f"call for all N (the batch's answers are the single calls', bit for bit, unless noted below).",
        f"- **ik_LM** (roboticstoolbox-python {versions.get('ik_LM', 'not run')}): the C++ Levenberg-"
        f"Marquardt solver, method 'chan', `ets.ik_LM(T, ilimit={RTB_ILIMIT}, slimit={RTB_SLIMIT}, "
        f"tol={RTB_TOL:g}, joint_limits=True)` (the same budget as ours: {RTB_ILIMIT} steps x {RTB_SLIMIT} "
        f"searches; tol bounds E = ½|e|², so |e| ≤ 4.5e-7) on the link's ETS, built once from the same "
        f"URDF text; q0=None (random starts); one call per target.",
        f"- **pytorch-kinematics** ({versions.get('ptk', 'not run')}): `PseudoInverseIK("
        f"max_iterations={PTK_MAX_ITERATIONS}, num_retries={PTK_RETRIES}, joint_limits=the chain's, "
        f"early_stopping_any_converged=True, pos_tolerance=rot_tolerance=1e-6)`, float64, CPU, one torch "
        f"thread, one batch over all N targets; its answer per target: the first converged retry, else "
        f"the retry of least error.",
        "",
        "Targets (issue): success ≥ 99.9 % on every robot at 1e-6 m / 1e-6 rad inside the limits, ≥ the "
        "best baseline's on each robot, and median time per solve ≤ ik_LM's on the same targets "
        "(single calls). Steps per target, median / mean / max: " + "; ".join(steps) + ".",
    ])
    if errors:
        note += "\n\n" + "\n".join(f"- {DISPLAY.get(k, k)} not run: {v}" for k, v in errors.items())
    if notes:
        note += "\n\nFailed answers:\n\n" + "\n".join(f"- {line}" for line in notes)
    report.add(f"Inverse kinematics, {N} random reachable targets per robot (success %, µs per solve)",
               table(headers, rows), note)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.ik", description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1000, help="targets per robot (default 1000)")
    parser.add_argument("--robots", help=f"comma-separated subset of {', '.join(r for r, _ in IK_ROBOTS)}")
    parser.add_argument("--max-iterations", type=int, help="ours: steps per attempt (default: the library's)")
    parser.add_argument("--restarts", type=int, help="ours: restarts (default: the library's)")
    parser.add_argument("--no-baselines", action="store_true", help="ours only")
    args = parser.parse_args(argv)
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        run(Report(), n=args.n, robots=args.robots.split(",") if args.robots else None,
            max_iterations=args.max_iterations, restarts=args.restarts, baselines=not args.no_baselines)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
