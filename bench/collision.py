"""Self-collision (``--only collision``, writes ``RESULTS_COLLISION.md``): ur5 and panda with their
catalogue meshes, 10,000 random configurations, on the pairs the allowed-collision matrix leaves
enabled: our batch (batched FK, sphere / box / hull broad phase, coal's narrow phase) against
Pinocchio's ``computeCollisions`` loop over the same geometry pairs (``buildGeomFromUrdf``,
``COLLISION``), and the agreement: the same colliding pairs per configuration, the minimum
distance within 1e-6 m."""

from __future__ import annotations

import numpy as np

from kinematics.algorithms import self_collision
from kinematics.io.catalogue import default_catalogue, example_robot_data_dir
from kinematics.verify.pinocchio import PinocchioCollision, compare_collision

from .common import Report, configurations, measure, ms, table

ROBOTS = ("ur5", "panda")


def run(report: Report, quick: bool = False) -> None:
    n = 1_000 if quick else 10_000
    n_dist = 200 if quick else 1_000
    rounds = 2 if quick else 3
    package_dirs = [example_robot_data_dir().parent.parent]
    cat = default_catalogue()
    rows = []
    for rid in ROBOTS:
        model = cat.get(rid)
        cm = self_collision.geometry(model)
        pairs = self_collision.matrix(model).enabled()
        Q = configurations(model, n)
        pc = PinocchioCollision(model, pairs, package_dirs)
        Qp = np.array([pc.ref.to_pinocchio_q(q) for q in Q])
        t = measure({"ours": lambda: cm.check(Q, pairs), "pin": lambda: pc.run_loop(Qp)}, rounds=rounds,
                    min_time=0.0)
        ours = cm.check(Q, pairs)
        agreement = compare_collision(model, Q, pairs, package_dirs, ours.pairs)
        dist = cm.check(Q[:n_dist], pairs, distance=True)
        d_agree = compare_collision(model, Q[:n_dist], pairs, package_dirs, dist.pairs, distances=dist.min_distance)
        geometry_pairs = len(pc.owner)
        rows.append([rid, f"{len(cm.links)} / {len(model.links)}", f"{len(pairs)} ({geometry_pairs})", f"{n:,}",
                     f"{100 * ours.colliding.mean():.1f} %", ms(t["ours"]), ms(t["pin"]),
                     f"**{t['ours'] / t['pin']:.2f}**", f"{100 * agreement.fraction:.2f} %",
                     f"{d_agree.max_distance_error:.1e}"])
    report.add(
        f"Self-collision, batch of {n:,} random configurations (catalogue meshes; ms per batch)",
        table(["robot", "links with geometry", "pairs checked (geometry pairs)", "configurations", "in collision",
               "ours", "Pinocchio loop", "ratio", "same pairs", f"max distance error ({n_dist:,} cfg)"], rows),
        note="Pairs: the allowed-collision matrix's enabled pairs (adjacent, always and never pairs disabled; "
             "10,000 samples). Pinocchio: `computeCollisions(model, data, geom_model, geom_data, q)` per "
             "configuration on the same geometry pairs (its FK and placements included, as ours includes our "
             "FK). Distances: the minimum over the pairs, where both answers are positive.")
