"""The same IK calls timed on two revisions of this repository, interleaved in one run
(``python -m bench.revisions BEFORE AFTER``): a restructuring must answer as fast as before.

Each revision is checked out (``git worktree add --detach``) into a temporary folder; a child
process with that checkout first on ``PYTHONPATH`` runs the calls below and prints, per call, the
best CPU time per call of its thread over a few repeats (one engine thread, BLAS one thread). The
children of the two revisions take turns (``--rounds``, default 5); each figure is the best of its
rounds, and the ratio is after / before. The first round of each also compiles or loads the numba
kernels (its times are kept too: the best of the rounds is what counts).

The calls are what a user makes through the library's IK entry points, on the UR5 (a closed-form
family) and the Panda with ``panda_joint7`` locked (the spherical-shoulder family, reversed):

- ``ik one``: ``kinematics.ik(model, T, link=...)``, one target per call (the numerical solver);
- ``ik all``: ``kinematics.ik(model, T, link=..., solutions="all")``, one target per call;
- ``all_solutions``: ``kinematics.algorithms.ik_all.all_solutions`` on a batch of 1,000 targets
  (microseconds per target);
- ``ik path``: ``kinematics.ik_path`` of a 50-waypoint straight line.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

#: the child's code: prints {call: best µs per call}
CHILD = r'''
import json, sys, time
import numpy as np
import kinematics
from kinematics.algorithms.ik_all import all_solutions

cat = kinematics.default_catalogue()
out = {}

def best(name, fn, per=1, repeats=5):
    fn()  # loads (or compiles) the kernels
    b = float("inf")
    for _ in range(repeats):
        t0 = time.thread_time()
        fn()
        b = min(b, time.thread_time() - t0)
    out[name] = 1e6 * b / per

for robot, link, locked in (("ur5", "tool0", None), ("panda", "panda_link8", {"panda_joint7": 0.3})):
    model = cat.get(robot)
    rng = np.random.default_rng(7)
    Q = model.sample_configurations(1000, rng)
    if locked:
        Q[:, model.q_index["panda_joint7"]] = 0.3
    T = kinematics.compile_model(model).fk(Q, [link])[:, 0]
    extra = {"locked": locked} if locked else {}
    best(f"{robot} ik one (20 targets, per target)",
         lambda: [kinematics.ik(model, T[i], link=link, **extra) for i in range(20)], per=20)
    best(f"{robot} ik all (20 targets, per target)",
         lambda: [kinematics.ik(model, T[i], link=link, solutions="all", **extra) for i in range(20)], per=20)
    best(f"{robot} all_solutions (1,000 targets, per target)",
         lambda: all_solutions(model, link, T, locked=locked, limits="ignore"), per=1000)
    if robot == "ur5":
        a = T[0].copy()
        b = a.copy()
        b[:3, 3] += [0.0, 0.05, 0.02]
        best(f"{robot} ik path (2 waypoints, a 50-step line)",
             lambda: kinematics.ik_path(model, np.stack([a, b]), link=link, seed=Q[0], step={"position": 0.001}),
             repeats=3)
print(json.dumps(out))
'''


def checkout(rev: str, where: Path) -> Path:
    """A detached work tree of ``rev`` under ``where``."""
    path = where / rev.replace("/", "_")
    subprocess.run(["git", "worktree", "add", "--detach", "-q", str(path), rev], check=True)
    return path


def run(tree: Path) -> dict[str, float]:
    env = dict(os.environ, PYTHONPATH=str(tree), KIN_THREADS="1", OPENBLAS_NUM_THREADS="1",
               OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    done = subprocess.run([sys.executable, "-c", CHILD], cwd=tree, env=env, capture_output=True, text=True)
    if done.returncode:
        raise SystemExit(f"the calls failed on {tree.name}:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.revisions", description=__doc__.splitlines()[0])
    parser.add_argument("before", help="a git revision (the older)")
    parser.add_argument("after", nargs="?", default="HEAD", help="a git revision (default HEAD)")
    parser.add_argument("--rounds", type=int, default=5, help="turns of each revision (default 5)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="revisions-") as tmp:
        trees = [checkout(rev, Path(tmp)) for rev in (args.before, args.after)]
        try:
            best: list[dict[str, float]] = [{}, {}]
            for r in range(args.rounds):
                for i, tree in enumerate(trees):
                    for name, us in run(tree).items():
                        best[i][name] = min(best[i].get(name, float("inf")), us)
                print(f"round {r + 1} of {args.rounds} done", file=sys.stderr)
        finally:
            for tree in trees:
                subprocess.run(["git", "worktree", "remove", "--force", str(tree)], check=False)
    print(f"| call | {args.before} µs | {args.after} µs | after / before |")
    print("|---|---|---|---|")
    for name in best[0]:
        a, b = best[0][name], best[1].get(name, float("nan"))
        print(f"| {name} | {a:.1f} | {b:.1f} | {b / a:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
