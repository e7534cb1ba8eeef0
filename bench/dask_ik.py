"""Every IK solution of a generated Parquet dataset of targets on Dask: a LocalCluster of 2 worker
processes against 1 (target >= 1.7x), the answers equal to a local run's, the peak memory of a
worker, and the extrapolation to 10^8 targets.

    PYTHONPATH=$PWD .venv/bin/python -m bench.dask_ik --rows 20000 [--model ur5 --link tool0]
        [--limits respect|ignore] [--partitions 40] [--write]

The dataset: ``--link``'s poses at configurations uniform within the limits (the columns of
``kinematics fk``'s Parquet output and a ``time`` column), one file of ``--partitions`` row groups,
one partition each (so that 2 workers share the work evenly). The timed run is what
``kinematics ik --all --dask local:N targets.parquet -o dir`` runs once the cluster is up and the
kernels are compiled on every worker: ``distributed.ik_all_dask(read_parquet_columns(...),
model, IKAllTask(...)).to_parquet(dir)``, the partitions' lengths counted first. A partition is
solved in chunks of ``IKAllTask.chunk`` targets, so a worker holds one partition of targets, one
chunk's solver state and the partition's solutions, whatever the dataset's length. ``--write``
replaces bench/RESULTS_DASK_IK.md.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from .common import Report, table

TARGET = 1.7
#: targets a write of the generated dataset holds at once (its memory is bounded whatever --rows)
WRITE_CHUNK = 100_000


def columns(link: str) -> tuple[str, ...]:
    return tuple(f"{link}.{c}" for c in ("x", "y", "z", "qw", "qx", "qy", "qz"))


def write_targets(path: str, model, link: str, n: int, partitions: int) -> None:
    """``n`` target poses of ``link`` in one Parquet file of ``partitions`` row groups."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from kinematics import fk
    from kinematics.io.parquet import result_columns

    rng = np.random.default_rng(0)
    group = -(-n // partitions)
    writer = None
    try:
        for start in range(0, n, max(group, WRITE_CHUNK - WRITE_CHUNK % group)):
            m = min(n - start, max(group, WRITE_CHUNK - WRITE_CHUNK % group))
            T = fk(model, model.sample_configurations(m, rng), links=[link]).poses
            t = pa.table({"time": pa.array(np.arange(start, start + m, dtype=np.int64)),
                          **result_columns("fk", T, [link])})
            writer = writer or pq.ParquetWriter(path, t.schema)
            writer.write_table(t, row_group_size=group)
    finally:
        if writer is not None:
            writer.close()


def cpu_seconds() -> float:
    """This process's CPU time so far (user + system), seconds."""
    import resource

    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def peak_rss_mib() -> float:
    """This process's peak resident memory, MiB (Linux: ru_maxrss in KiB)."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def run(report: Report, rows: int, model_id: str, link: str, limits: str, partitions: int,
        workers_list=(1, 2)) -> dict:
    import pyarrow.parquet as pq

    from kinematics import default_catalogue, distributed
    from kinematics.io.parquet import ParquetTargetRows
    from kinematics.usecases import Query, ik
    from kinematics.usecases.ik_options import IKOptions, SolutionSet

    model = default_catalogue().get(model_id)
    cols = columns(link)
    options = IKOptions(solutions=SolutionSet("all", solution_limits=limits))
    task = distributed.IKAllTask(link, options, cols)
    load_before = os.getloadavg()
    tmp = tempfile.mkdtemp(prefix="bench-dask-ik-")
    try:
        src = os.path.join(tmp, "targets.parquet")
        write_targets(src, model, link, rows, partitions)
        # one local process, the same chunks: the reference answers and rate
        query = Query(model, link=link)
        with ParquetTargetRows(src, task.chunk) as reader:
            ik(query, next(iter(reader))[1][:8], options=options)  # kernels compiled before the clock
        t0 = time.perf_counter()
        local_rows = []
        with ParquetTargetRows(src, task.chunk) as reader:
            for start, T in reader:
                local_rows.append(distributed.ik_all_rows(ik(query, T, options=options), start))
        local_rate = rows / (time.perf_counter() - t0)
        want = {k: np.concatenate([r[k] for r in local_rows]) for k in local_rows[0]}
        out, lines, same = {}, [], True
        for workers in workers_list:
            t1 = time.perf_counter()
            client = distributed.connect(f"local:{workers}")
            spec = distributed.model_spec(model_id)
            distributed.warm_up(client, spec)
            distributed.warm_up_ik(client, spec, task)
            started = time.perf_counter() - t1
            dest = os.path.join(tmp, f"out_{workers}")
            try:
                cpu0 = client.run(cpu_seconds)
                t2 = time.perf_counter()
                ddf = distributed.read_parquet_columns(src, cols, blocksize=1)  # a partition per row group
                lengths = client.compute(ddf.map_partitions(len), sync=True).tolist()
                distributed.ik_all_dask(ddf, spec, task, lengths=lengths).to_parquet(
                    dest, write_index=False, name_function=distributed.part_name, **distributed.WRITE_OPTIONS)
                wall = time.perf_counter() - t2
                cpu1 = client.run(cpu_seconds)
                cpu = sum(cpu1[w] - cpu0[w] for w in cpu1)  # the workers' CPU time in the run, load or not
                rss = max(client.run(peak_rss_mib).values())
            finally:
                distributed.close(client)
            got = pq.read_table(dest)
            same &= all(np.array_equal(got.column(k).to_numpy(), v) for k, v in want.items())
            rate = rows / wall
            out[workers] = {"wall": wall, "rate": rate, "rss": rss, "cpu": cpu}
            lines.append([workers, len(lengths), f"{started:.1f}", f"{wall:.1f}", f"{rate:,.0f}", f"{rate / workers:,.0f}",
                          f"{cpu:.1f}", f"{got.num_rows:,}", f"{rss:,.0f}"])
        load_after = os.getloadavg()
        result = {"same": same, "local_rate": local_rate, **out}
        if 1 in out and 2 in out:
            speedup = out[1]["wall"] / out[2]["wall"]
            cpu_ratio = out[2]["cpu"] / out[1]["cpu"]
            lines.append(["2 vs 1", "", "", f"**{speedup:.2f}x**", "yes" if speedup >= TARGET else "no", "",
                          f"{cpu_ratio:.2f}x", "", ""])
            result["speedup"], result["cpu_ratio"] = speedup, cpu_ratio
        best = max(out[w]["rate"] / w for w in out)
        hours = 1e8 / best / 3600
        solutions = len(want["target"]) / rows
        report.add(f"`ik --all` on Dask: {rows:,} {model_id} targets ({link}, limits {limits}, {solutions:.1f} "
                   "solutions a target) on a LocalCluster of 1 and 2 worker processes",
                   table(["workers", "partitions", "cluster start + warm-up (s)", "wall (s)", "targets/s",
                          "targets/s per worker", "workers' CPU (s)", "solution rows", "peak RSS of a worker (MiB)"],
                         lines),
                   f"Answers equal to a local run's (every column, every row): {same}. Target 2 workers >= {TARGET}x "
                   "one. The workers' CPU time (summed) depends little on the load: a 2-vs-1 ratio near 1 says the "
                   "work splits without overhead, so that on idle cores the wall time halves. "
                   f"One local process solves {local_rate:,.0f} targets/s. Extrapolation at the best rate per "
                   f"worker ({best:,.0f} targets/s): 10^8 targets take {hours:.1f} worker-hours, "
                   f"{hours * 60 / 64:.0f} min on 64 workers, and write {solutions * 1e8:.2g} solution rows. What a task "
                   f"holds is bounded by design, whatever the dataset's length: one partition of "
                   f"{-(-rows // partitions):,} targets, a chunk of {task.chunk:,} in the solver, the partition's "
                   "solutions (keep a partition to ~10^5 targets with --limits respect); the peak RSS column is the "
                   "measured worker process (numba, Dask, pyarrow included): compare it across --rows at the same "
                   f"partition size. Load average (2 cores) before {load_before[0]:.1f}, after {load_after[0]:.1f}.")
        return result
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(prog="python -m bench.dask_ik", description=__doc__.splitlines()[0])
    p.add_argument("--rows", type=int, default=20_000, help="targets in the generated dataset (default 20000)")
    p.add_argument("--model", default="ur5")
    p.add_argument("--link", default="tool0")
    p.add_argument("--limits", choices=("respect", "ignore"), default="respect",
                   help="the solution set (the command's --limits; default respect)")
    p.add_argument("--partitions", type=int, default=40, help="row groups of the dataset, one partition each")
    p.add_argument("--write", action="store_true", help="replace bench/RESULTS_DASK_IK.md")
    a = p.parse_args(argv)
    report = Report()
    run(report, a.rows, a.model, a.link, a.limits, a.partitions)
    if a.write:
        path = Path(__file__).with_name("RESULTS_DASK_IK.md")
        command = f"PYTHONPATH=$PWD .venv/bin/python -m bench.dask_ik --rows {a.rows} --limits {a.limits} --write"
        path.write_text(f"# Every IK solution on Dask\n\nCommand (from the checkout): `{command}`\n\n"
                        + "\n".join(report.sections))


if __name__ == "__main__":  # pragma: no cover
    main()
