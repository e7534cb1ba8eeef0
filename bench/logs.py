"""Pipelines at scale: every core, one configuration, a 10,000,000-row Parquet log, Dask.

Tables (``python -m bench.run_all --only logs --output bench/RESULTS.md`` writes them to
``bench/RESULTS_LOGS.md``; ``python -m bench.logs`` prints them):

1. Threads: 1,000,000-configuration FK of all links and Jacobians, and an IK batch, on 1 and 2
   threads (wall time; target 2 threads >= 1.7x one), answers bit-identical.
2. One configuration: ``kinematics.fk_function`` / ``jacobian_function`` (the tool link) against
   Pinocchio's single call (target <= 2x), with the batch path ``PoEModel.fk(q[None])`` for scale.
3. A 10,000,000-row Parquet log of ur5 joint states -> a Parquet of tool poses through
   ``kinematics fk`` (a child process): rows/s, rows/s per core and its peak memory (target
   < 1 GiB; the same run on 1,000,000 rows shows it does not grow with the length).
4. The same on Dask (``kinematics.distributed``): a LocalCluster of 2 worker processes against
   1 (target >= 1.6x), and the extrapolation to 10^9 samples.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

from .common import Report, best_of, configurations, measure, run_parts, table, us

THREAD_TARGET = 1.7
SINGLE_TARGET = 2.0
DASK_TARGET = 1.6
MEMORY_LIMIT = 1 << 30
LOG_ROWS = 10_000_000
ROW_GROUP = 250_000
CLI_CHUNK = 100_000


def threads_table(report: Report, quick: bool) -> list[dict]:
    from kinematics import api, compile_model, default_catalogue, threads

    n = 200_000 if quick else 1_000_000
    n_ik = 2_000 if quick else 20_000
    rows, out = [], []
    for rid, link in (("ur5", "tool0"), ("panda", "panda_hand_tcp")):
        model = default_catalogue().get(rid)
        poe = compile_model(model)
        Q = configurations(model, n)
        T = poe.fk(Q[:n_ik], [link])[:, 0].copy()
        cases = {
            f"FK, all {len(model.links)} links, N = {n:,}": lambda: poe.fk(Q),
            f"Jacobian of {link} (world), N = {n:,}": lambda: poe.jacobian(Q, link),
            f"IK of {link}, {n_ik:,} reachable targets": lambda: api.ik(model, T, link=link).solution.q,
        }
        for what, fn in cases.items():
            t, answers = {}, {}
            for k in (1, 2):
                with threads(k):
                    answers[k] = np.array(fn(), copy=True)
                    t[k] = best_of(fn, rounds=2 if "IK" in what else 3)
            same = bool(np.array_equal(answers[1], answers[2]))
            ratio = t[1] / t[2]
            out.append({"robot": rid, "what": what, "speedup": ratio, "identical": same})
            rows.append([rid, what, f"{t[1] * 1e3:.1f}", f"{t[2] * 1e3:.1f}", f"**{ratio:.2f}**",
                         "yes" if ratio >= THREAD_TARGET else "no", "yes" if same else "**NO**"])
    report.add("Every core: 2 threads against 1 (wall time, ms)",
               table(["robot", "batch", "1 thread", "2 threads", "speed-up", f"≥ {THREAD_TARGET}?",
                      "bit-identical"], rows),
               "`with kinematics.threads(k):` around the batch call (`KIN_THREADS` sets the default, else the "
               "cores available). FK and Jacobians: one contiguous range of rows per thread on the `nogil` "
               "kernels; IK: pieces of 4 targets taken in turn (targets differ in cost). Best of 3 (IK 2).")
    return out


def single_table(report: Report, quick: bool) -> list[dict]:
    import pinocchio as pin

    from kinematics import compile_model, default_catalogue, fk_function, jacobian_function
    from kinematics.verify.pinocchio import reference_for

    rows, out = [], []
    for rid, link in (("ur5", "tool0"), ("panda", "panda_hand_tcp")):
        model = default_catalogue().get(rid)
        poe = compile_model(model)
        q = configurations(model, 1)[0]
        Q1 = q[None].copy()
        ref = reference_for(model)
        pm = ref.pin_model
        data = pm.createData()
        x = ref.to_pinocchio_q(q)
        fid = ref.frame_ids[link]
        fk1 = fk_function(poe, link)
        J1 = jacobian_function(poe, link, "world")
        out4 = np.empty((4, 4))
        world = pin.ReferenceFrame.WORLD
        assert np.array_equal(fk1(q), poe.fk(Q1, [link])[0, 0]) and np.array_equal(J1(q), poe.jacobian(Q1, link)[0])

        def pin_fk():
            pin.forwardKinematics(pm, data, x)
            pin.updateFramePlacements(pm, data)

        t = measure({"fk1": lambda: fk1(q), "fk1_out": lambda: fk1(q, out4), "batch": lambda: poe.fk(Q1, [link]),
                     "J1": lambda: J1(q), "batchJ": lambda: poe.jacobian(Q1, link),
                     "pin_fk": pin_fk, "pin_frame": lambda: pin.updateFramePlacement(pm, data, fid),
                     "pin_J": lambda: pin.computeFrameJacobian(pm, data, x, fid, world)},
                    rounds=15 if quick else 40, min_time=0.02)
        r_fk, r_j = t["fk1"] / t["pin_fk"], t["J1"] / t["pin_J"]
        out.append({"robot": rid, "fk_ratio": r_fk, "jacobian_ratio": r_j})
        rows.append([rid, link, us(t["fk1"]), us(t["fk1_out"]), us(t["batch"]), us(t["pin_fk"]), f"**{r_fk:.2f}**",
                     "yes" if r_fk <= SINGLE_TARGET else "no", us(t["J1"]), us(t["batchJ"]), us(t["pin_J"]),
                     f"**{r_j:.2f}**", "yes" if r_j <= SINGLE_TARGET else "no"])
    report.add("One configuration: the tool link's pose and Jacobian (µs per call)",
               table(["robot", "link", "FK `fk_function`", "with out=", "batch path `fk(q[None])`",
                      "Pinocchio FK + frames", "ratio", f"≤ {SINGLE_TARGET}?", "Jacobian `jacobian_function`",
                      "batch path", "Pinocchio `computeFrameJacobian`", "ratio", f"≤ {SINGLE_TARGET}?"], rows),
               "`f = kinematics.fk_function(model, link)` binds the kernel tables and a per-thread scratch "
               "once; `f(q)` is one call of a compiled entry (bit-identical to the batch row). Pinocchio: "
               "`forwardKinematics` + `updateFramePlacements` (every frame) and `computeFrameJacobian` "
               "(`WORLD`), on a pre-converted q. CPU time of this thread, best of interleaved rounds. What "
               "bounds ours: the compiled work is ~0.2 µs (ur5); entering numba from Python costs ~0.35 µs "
               "(its dispatcher types the 4 arguments), the Python closure, its argument check and the "
               "result's allocation ~0.3 µs.")
    return out


# ---------------------------------------------------------------------------- the log
def write_log(path: str, rows: int, seed: int = 7) -> None:
    """A Parquet log of ur5 joint states (columns by joint name + ``time`` int64 ns), streamed."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from kinematics import default_catalogue

    model = default_catalogue().get("ur5")
    rng = np.random.default_rng(seed)
    lo, hi = model.lower_limits, model.upper_limits
    schema = pa.schema([("time", pa.int64())] + [(n, pa.float64()) for n in model.joint_names])
    with pq.ParquetWriter(path, schema) as w:
        for a in range(0, rows, ROW_GROUP):
            m = min(ROW_GROUP, rows - a)
            Q = lo + (hi - lo) * rng.random((m, model.dof))
            cols = [pa.array(np.arange(a, a + m, dtype=np.int64) * 2_000_000)] + [pa.array(Q[:, k]) for k in range(model.dof)]
            w.write_table(pa.Table.from_arrays(cols, schema=schema))


#: runs `kinematics ARGS` and writes the process's peak resident memory (VmHWM, kB) to a file: the
#: rusage of a child (wait4) would count the benchmark's own memory, inherited through fork
_WRAPPER = ("import sys\nfrom kinematics.cli import main\ncode = main(sys.argv[2:])\n"
            "hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM')][0].split()[1]\n"
            "open(sys.argv[1], 'w').write(hwm)\nsys.exit(code)")


def _child(args: list[str], env: dict[str, str] | None = None) -> tuple[float, int]:
    """Wall seconds and peak resident memory (bytes) of ``kinematics ARGS`` in a child process."""
    with tempfile.NamedTemporaryFile("r", suffix=".hwm") as hwm:
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", _WRAPPER, hwm.name] + args, env={**os.environ, **(env or {})},
                       stdout=subprocess.DEVNULL, check=True)
        elapsed = time.perf_counter() - t0
        return elapsed, int(open(hwm.name).read()) * 1024


def log_tables(report: Report, quick: bool) -> dict:
    rows_n = 1_000_000 if quick else LOG_ROWS
    tmp = tempfile.mkdtemp(prefix="kin-bench-logs-")
    results: dict = {}
    try:
        big = os.path.join(tmp, "log.parquet")
        small = os.path.join(tmp, "log_small.parquet")
        t0 = time.perf_counter()
        write_log(big, rows_n)
        write_log(small, rows_n // 10)
        made = time.perf_counter() - t0
        rows = []
        for label, src, n, threads in (("log", big, rows_n, 1), ("log", big, rows_n, 2),
                                       ("a tenth of it", small, rows_n // 10, 1)):
            out = os.path.join(tmp, "poses.parquet")
            wall, peak = _child(["fk", "--model", "ur5", "--links", "tool0", src, "-o", out,
                                       "--chunk", str(CLI_CHUNK)], {"KIN_THREADS": str(threads)})
            rate = n / wall
            results[(label, threads)] = {"rows_per_s": rate, "peak": peak, "wall": wall}
            rows.append([f"{n:,} ({label})", threads, f"{wall:.1f}", f"{rate:,.0f}", f"{rate / threads:,.0f}",
                         f"{peak / 2**20:,.0f}", "yes" if peak < MEMORY_LIMIT else "**no**"])
        one, two = results[("log", 1)], results[("log", 2)]
        report.add(f"A {rows_n:,}-row Parquet log of ur5 joint states -> Parquet of tool poses (`kinematics fk`)",
                   table(["rows", "KIN_THREADS", "wall (s)", "rows/s", "rows/s per core", "peak memory (MiB)",
                          "< 1 GiB?"], rows),
                   f"`KIN_THREADS=k python -m kinematics fk --model ur5 --links tool0 log.parquet -o poses.parquet "
                   f"--chunk {CLI_CHUNK}` in a child process (start-up, model load and kernel cache included); "
                   f"peak memory: the child's high-water resident set (`VmHWM`). The log: row groups of {ROW_GROUP:,}, "
                   f"columns `time` (int64 ns) and the 6 joints by name (made in {made:.0f} s); the output: `time` "
                   f"and `tool0.x ... tool0.qz`, one row group per chunk. The same peak for a tenth of the rows: "
                   f"memory is bounded by the chunk, not the length. 2 threads vs 1: {one['wall'] / two['wall']:.2f}x "
                   "(only the kinematics is threaded; reading, quaternions and Parquet encoding are per chunk on "
                   "one thread).")
        results["dask"] = dask_table(report, big, rows_n, tmp, one["rows_per_s"])
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return results


def dask_table(report: Report, src: str, rows_n: int, tmp: str, local_rate: float) -> dict:
    from kinematics import distributed

    out: dict = {}
    rows = []
    for workers in (1, 2):
        t0 = time.perf_counter()
        client = distributed.connect(f"local:{workers}")
        distributed.warm_up(client, distributed.model_spec("ur5"))  # imports + the model, once per worker
        started = time.perf_counter() - t0
        try:
            dest = os.path.join(tmp, f"dask_{workers}")
            t1 = time.perf_counter()
            ddf = distributed.read_joint_parquet(src, "ur5")
            distributed.fk_dask(ddf, "ur5", links=["tool0"]).to_parquet(dest, write_index=False,
                                                                         **distributed.WRITE_OPTIONS)
            wall = time.perf_counter() - t1
            parts = ddf.npartitions
        finally:
            cluster = getattr(client, "_kinematics_cluster", None)
            client.close()
            if cluster is not None:
                cluster.close()
        shutil.rmtree(dest, ignore_errors=True)
        rate = rows_n / wall
        out[workers] = {"wall": wall, "rate": rate, "start": started}
        rows.append([workers, parts, f"{started:.1f}", f"{wall:.1f}", f"{rate:,.0f}", f"{rate / workers:,.0f}"])
    speedup = out[1]["wall"] / out[2]["wall"]
    out["speedup"] = speedup
    per_core = out[2]["rate"] / 2
    rows.append(["2 vs 1", "", "", f"**{speedup:.2f}x**", "yes" if speedup >= DASK_TARGET else "no", ""])
    hours = 1e9 / per_core / 3600
    report.add(f"Dask: the {rows_n:,}-row log on a LocalCluster of 1 and 2 worker processes",
               table(["workers", "partitions", "cluster start + warm-up (s)", "wall (s)", "rows/s", "rows/s per core"], rows),
               "`distributed.fk_dask(distributed.read_joint_parquet(log, 'ur5'), 'ur5', links=['tool0'])"
               ".to_parquet(dir)` (what `kinematics fk ... --dask local:N -o dir` runs), one thread per worker, "
               f"partitions of ~{distributed.DEFAULT_BLOCKSIZE} of row groups; wall time of the run (the "
               f"cluster's start and the workers' warm-up apart). Target 2 workers ≥ {DASK_TARGET}x one. Extrapolation at "
               f"{per_core:,.0f} rows/s per core: 10^9 samples take {hours:.2f} core-hours ({hours * 60:.0f} core-minutes), "
               f"e.g. {hours * 3600 / 64:.0f} s on 64 worker cores (reading and writing on storage that keeps up). "
               f"The local command line does {local_rate:,.0f} rows/s on one core.")
    return out


def run(report: Report, quick: bool = False) -> dict:
    return {"threads": threads_table(report, quick), "single": single_table(report, quick),
            "log": log_tables(report, quick)}


if __name__ == "__main__":  # pragma: no cover
    run_parts("python -m bench.logs", __doc__,
              {"threads": threads_table, "single": single_table, "log": log_tables},
              default="threads,single,log")
