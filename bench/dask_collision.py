"""Self-collision of a generated Parquet log on Dask: a LocalCluster of 2 worker processes
against 1 (target >= 1.7x), the answers equal to a local run's, and the extrapolation to 10^8 rows.

``python -m bench.dask_collision`` (``--quick``: 20,000 rows instead of 200,000). The log: ur5
joint states uniform within the limits (a ``time`` column and the 6 joints by name), 40 row
groups, one partition each (so that 2 workers share the work evenly); the matrix (10,000 samples) is computed once into a cache directory the workers share,
so the timed run is the check itself: ``distributed.collision_dask(read_joint_parquet(log),
'ur5', CollisionTask(cache_dir=...)).to_parquet(dir)``, what ``kinematics collision log/ --dask
local:N -o dir`` runs. A partition is checked in slices of ``CollisionTask.chunk`` rows, so a
worker's memory is bounded by the partition and the slice, not by the log's length.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time

import numpy as np

from .common import Report, run_parts, table

TARGET = 1.7
PARTITIONS = 40


def _write_log(path: str, n: int) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    from kinematics import default_catalogue

    ur5 = default_catalogue().get("ur5")
    Q = ur5.sample_configurations(n, np.random.default_rng(0))
    cols = {"time": pa.array(np.arange(n, dtype=np.int64))}
    cols.update({name: pa.array(Q[:, k]) for k, name in enumerate(ur5.joint_names)})
    pq.write_table(pa.table(cols), path, row_group_size=-(-n // PARTITIONS))


def _warm_check(cache: str) -> None:
    from kinematics import api, distributed

    model = distributed.worker_model(("id", "ur5"))
    api.collision(model, model.sample_configurations(64, np.random.default_rng(1)), cache_dir=cache)


def dask_table(report: Report, quick: bool = False) -> dict:
    import pyarrow.parquet as pq

    from kinematics import api, default_catalogue, distributed

    n = 20_000 if quick else 200_000
    tmp = tempfile.mkdtemp(prefix="bench-dask-collision-")
    try:
        src = os.path.join(tmp, "log.parquet")
        _write_log(src, n)
        cache = os.path.join(tmp, "cache")
        ur5 = default_catalogue().get("ur5")
        api.collision_matrix(ur5, cache_dir=cache)  # once, shared by the workers through the directory
        task = distributed.CollisionTask(cache_dir=cache)
        api.collision(ur5, ur5.sample_configurations(64, np.random.default_rng(1)), cache_dir=cache)  # warm
        t0 = time.perf_counter()
        Q = pq.read_table(src).select(list(ur5.joint_names)).to_pandas().to_numpy()
        local = api.collision(ur5, Q, cache_dir=cache)
        local_rate = n / (time.perf_counter() - t0)
        out, rows, answers = {}, [], {}
        for workers in (1, 2):
            t1 = time.perf_counter()
            client = distributed.connect(f"local:{workers}")
            distributed.warm_up(client, distributed.model_spec("ur5"))
            client.run(_warm_check, cache)  # the matrix read back, the check's kernels compiled, on every worker
            started = time.perf_counter() - t1
            dest = os.path.join(tmp, f"out_{workers}")
            try:
                t2 = time.perf_counter()
                ddf = distributed.read_joint_parquet(src, "ur5", blocksize=1)  # a partition per row group
                distributed.collision_dask(ddf, "ur5", task).to_parquet(dest, write_index=False,
                                                                        **distributed.WRITE_OPTIONS)
                wall = time.perf_counter() - t2
                parts = ddf.npartitions
            finally:
                distributed.close(client)
            answers[workers] = pq.read_table(dest).sort_by("time").column("colliding").to_numpy(zero_copy_only=False)
            rate = n / wall
            out[workers] = {"wall": wall, "rate": rate}
            rows.append([workers, parts, f"{started:.1f}", f"{wall:.1f}", f"{rate:,.0f}", f"{rate / workers:,.0f}"])
        same = all(np.array_equal(answers[w], local.colliding) for w in (1, 2))
        speedup = out[1]["wall"] / out[2]["wall"]
        rows.append(["2 vs 1", "", "", f"**{speedup:.2f}x**", "yes" if speedup >= TARGET else "no", ""])
        per_core = out[2]["rate"] / 2
        hours = 1e8 / per_core / 3600
        load = os.getloadavg()[0]
        report.add(f"Self-collision on Dask: a {n:,}-row ur5 log on a LocalCluster of 1 and 2 worker processes",
                   table(["workers", "partitions", "cluster start + warm-up (s)", "wall (s)", "rows/s",
                          "rows/s per core"], rows),
                   f"Answers equal to a local run's: {same}. Target 2 workers >= {TARGET}x one. Extrapolation at "
                   f"{per_core:,.0f} rows/s per core: 10^8 rows take {hours:.1f} core-hours, e.g. "
                   f"{hours * 60 / 64:.0f} min on 64 worker cores (memory per worker: one partition of joint values "
                   f"-- a row group, ~32 MiB at most with the default blocksize -- and a slice of {task.chunk:,} rows, "
                   "whatever the length). One local process "
                   f"checks {local_rate:,.0f} rows/s. Load average during the run: {load:.1f} (2 cores).")
        out["speedup"], out["same"] = speedup, same
        return out
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":  # pragma: no cover
    run_parts("python -m bench.dask_collision", __doc__, {"dask": dask_table}, default="dask")
