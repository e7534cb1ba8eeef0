"""The general 6R (``python -m bench.run_all --only ik-general``): the 16-degree elimination against the
multistart search and IK-Geo's general 6R.

Per random DH table (generic: no family), and a Jaco-like arm (the elimination on a cyclic shift of
the loop): ``n`` random configurations, their pose as the target.
Ours: :func:`kinematics.algorithms.ik_all.all_solutions` (``method="auto"``: the elimination of
:mod:`kinematics.algorithms.ik_general`) on the batch; the search: the same with ``method="numeric"``
(512 Halton seeds, damped Newton) on a tenth of the targets (it is slow); IK-Geo's ``gen_six_dof``
(a 2-D search, the ``ik-all-baselines`` extra) built from our own screws, one call per target, its
answers polished by the numerical solver and compared (its raw answers are 1e-4 away). Reported:
solutions per target, how often each misses the generating configuration, how many of the others'
solutions are not among ours, the worst error of ours, microseconds per target (the best of 3).
"""

from __future__ import annotations

import time

import numpy as np

from kinematics import compile_model
from kinematics.algorithms.ik import inverse_kinematics
from kinematics.algorithms.ik_all import all_solutions
from kinematics.algorithms.ik_families import detect, reduce_chain
from kinematics.io.dh_table import model_from_table, table_from_dict

from .common import Report, best_of, table

SAME = 1e-7


def _random_6r(seed: int):
    rng = np.random.default_rng(seed)
    rows = [{"type": "revolute", "a": float(rng.uniform(0.05, 0.5)), "alpha": float(rng.uniform(-3.0, 3.0)),
             "d": float(rng.uniform(-0.3, 0.3)), "theta": float(rng.uniform(-3.0, 3.0)), "limits": [-3.1, 3.1]}
            for _ in range(6)]
    return model_from_table(table_from_dict({"name": f"random_6r_{seed}", "convention": "standard", "joints": rows}))


def _jaco_like():
    """Axes 1, 2 meet, 2 ∥ 3, and axes 4, 5, 6 each meeting the next at 60° (no common point): the
    elimination degenerates on the chain and reversed, and runs on a cyclic shift of the loop."""
    table = [(np.pi / 2, 0, 0.2755), (np.pi, 0.41, 0), (np.pi / 2, 0, -0.0098), (1.047, 0, -0.2502),
             (1.047, 0, -0.0858), (np.pi, 0, -0.2116)]
    rows = [{"type": "revolute", "alpha": al, "a": a, "d": d, "theta": 0.0, "limits": [-3.1, 3.1]} for al, a, d in table]
    return model_from_table(table_from_dict({"name": "jaco_like", "convention": "standard", "joints": rows}))


def _contains(qs, q) -> bool:
    return len(qs) > 0 and bool(np.abs(np.mod(qs - q + np.pi, 2 * np.pi) - np.pi).max(axis=1).min() < SAME)


def run(report: Report, quick: bool = False) -> None:
    try:
        import ik_geo
    except ImportError:  # the bench extra is missing: the comparison with the search only
        ik_geo = None
    n = 50 if quick else 300
    rows = []
    for model in [_random_6r(seed) for seed in (101, 102, 103)] + [_jaco_like()]:
        link = model.leaf_links[0]
        chain = reduce_chain(model, link)
        fam = detect(chain)
        Q = model.sample_configurations(n, np.random.default_rng(2026), continuous_range=np.pi)
        T = compile_model(model).fk(Q, [link])[:, 0]
        all_solutions(model, link, T[:2], limits="ignore")
        t_ours = best_of(lambda: all_solutions(model, link, T, limits="ignore")) / n
        sol = all_solutions(model, link, T, limits="ignore")
        ours = [sol.q[i, :sol.count[i]] for i in range(n)]
        worst = max(float(np.nanmax(sol.position_error)), float(np.nanmax(sol.rotation_error)))
        m = max(1, n // 10)
        t0 = time.perf_counter()
        search = all_solutions(model, link, T[:m], limits="ignore", method="numeric")
        t_search = (time.perf_counter() - t0) / m
        theirs = [search.q[i, :search.count[i]] for i in range(m)]
        geo_sets, t_geo = None, float("nan")
        if ik_geo is not None:
            H = chain.h
            P = np.vstack([chain.r[0], np.diff(chain.r, axis=0), chain.M[:3, 3] - chain.r[-1]])
            geo = ik_geo.Robot.gen_six_dof(H.tolist(), P.tolist())
            Rg = T[:, :3, :3] @ chain.M[:3, :3].T

            def solve_geo():
                return [geo.get_ik(Rg[i].T.tolist(), T[i, :3, 3].tolist()) for i in range(m)]

            t_geo = best_of(solve_geo, 1) / m
            geo_sets = []
            for i, out in enumerate(solve_geo()):
                s = np.array([q for q, _ in out]).reshape(-1, 6)
                if len(s):
                    r = inverse_kinematics(model, link, np.repeat(T[i:i + 1], len(s), 0), s, restarts=0,
                                           position_tolerance=1e-10, rotation_tolerance=1e-10)
                    s = r.q[r.success]
                    keep = []
                    for q in s:
                        if not _contains(np.array(keep).reshape(-1, 6), q):
                            keep.append(q)
                    s = np.array(keep).reshape(-1, 6)
                geo_sets.append(s)
        miss_ours = sum(not _contains(ours[i], Q[i]) for i in range(n))
        miss_search = sum(not _contains(theirs[i], Q[i]) for i in range(m))
        search_not_ours = sum(int(not _contains(ours[i], q)) for i in range(m) for q in theirs[i])
        geo_cells = ["-", "-", "-", "-"]
        if geo_sets is not None:
            geo_cells = [f"{np.mean([len(s) for s in geo_sets]):.2f}", str(sum(not _contains(s, Q[i]) for i, s in enumerate(geo_sets))),
                         str(sum(int(not _contains(ours[i], q)) for i, s in enumerate(geo_sets) for q in s)), f"{t_geo * 1e6:.0f}"]
        rows.append([model.name, fam.name, n, f"{sol.count.mean():.2f}", int(sol.count.max()),
                     f"{search.count.mean():.2f} / {sol.count[:m].mean():.2f} ({m})", geo_cells[0],
                     f"{miss_ours} / {miss_search} / {geo_cells[1]}", f"{search_not_ours} / {geo_cells[2]}",
                     f"{worst:.1e}", f"{t_ours * 1e6:.0f}", f"{t_search * 1e6:.0f}", geo_cells[3]])
    report.add("General 6R: the elimination, the multistart search, IK-Geo's gen_six_dof", table(
        ["robot", "family", "targets", "ours / target", "ours max", "search / ours per target (first tenth)",
         "IK-Geo / target", "miss generating (ours / search / IK-Geo)", "theirs not ours (search / IK-Geo)",
         "worst error of ours", "ours µs", "search µs", "IK-Geo µs"], rows),
        "IK-Geo's answers are polished by the numerical solver before they are compared (raw, they are "
        "about 1e-4 off); the search and IK-Geo run on the first tenth of the targets.")
