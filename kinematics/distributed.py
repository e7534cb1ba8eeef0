"""Distributed runs on Dask: FK and Jacobians mapped over the partitions of a Parquet dataset.

When a log outgrows one machine, the computation runs on an existing engine:
``dask.dataframe`` splits the Parquet dataset into partitions and ``dask.distributed`` runs
one task per partition on the workers of a cluster. Each task reads its partition's joint
columns (by name), computes with the compiled kernels and returns the output columns of
:mod:`kinematics.io.parquet` (the time column first, then ``<link>.x ... <link>.qz`` or
``J<r><c>``); the result is written as a partitioned Parquet dataset, one file per partition.

- The model travels as a small spec (a catalogue id, or URDF text), never as compiled code:
  each worker process loads and compiles it **once** (a per-process cache, :func:`worker_model`)
  and reuses it for every partition it gets.
- A task computes on one thread (Dask already runs one task per worker thread); give
  ``threads`` to change that.
- Results equal a local run bit for bit: each row's answer does not depend on where it is
  computed (:mod:`kinematics.engine.parallel`).

For users who already have a Dask dataframe::

    import dask.dataframe as dd
    from kinematics.distributed import fk_dask

    ddf = dd.read_parquet("s3://bucket/run-*.parquet")
    poses = fk_dask(ddf, "ur5", links=["tool0"])      # lazy: a Dask dataframe of pose columns
    poses.to_parquet("s3://bucket/poses/")            # or .compute(), or further Dask work

The command line does the same: ``kinematics fk --model ur5 logs/ --dask local:2 -o poses/``
(``--dask tcp://scheduler:8786`` for a running cluster).

Self-collision maps the same way (:func:`collision_dask`, ``kinematics collision logs/ --dask
local:2 -o report/``): each partition answers ``colliding`` and ``pairs`` (the pairs in
collision, ``a|b`` joined by ``;``, as the local command's CSV) per row, on the matrix of the
task's :class:`CollisionTask` (samples, margin, cache, the user's pairs), the same on every
worker (a seeded matrix), so the answers equal a local run's. A partition is checked in
slices of ``CollisionTask.chunk`` rows: a worker's memory is bounded by the partition size
(``blocksize``) and the slice, whatever the dataset's length.

Every IK solution of a dataset of target poses maps the same way (:func:`ik_all_dask`, ``kinematics
ik --all targets/ --dask local:2 -o solutions/``): each partition answers the rows of the local
command's CSV (``target``, the joints, the errors, ``within_limits``, ``singular``), the targets
numbered across the dataset from the partitions' lengths (counted first), solved in chunks of
``IKAllTask.chunk`` targets; the output files are named in the partitions' order (:func:`part_name`).
"""

from __future__ import annotations

import hashlib
import os
import threading
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from . import api
from .engine.parallel import threads as _threads
from .engine.poe import compile_model
from .errors import KinematicsError, MissingExtraError
from .io.dh_table import load_table, table_to_urdf
from .io.parquet import TIME_COLUMN, WRITE_OPTIONS, result_columns
from .io.urdf import parse_urdf
from .model.robot import RobotModel

_cache: dict[str, RobotModel] = {}
_lock = threading.Lock()
#: how many times this process has loaded (and so compiled) a model: the tests read it
LOADS = {"count": 0}


def _dask():
    try:
        import dask.dataframe as dd
    except ImportError:  # pragma: no cover - the `dask` extra
        raise MissingExtraError.of("dask", "distributed runs", "dask") from None
    return dd


def model_spec(model: Any = None, *, model_id: str | None = None, urdf: str | None = None,
               dh: str | None = None) -> tuple[str, str]:
    """What a worker needs to load a model: ``("id", catalogue id)`` or ``("urdf", text)``.

    ``model``: a catalogue id, a spec already, or a path to a ``.urdf`` file; or name it with
    ``model_id``, ``urdf`` (a file) or ``dh`` (a DH table file, shipped as its generated URDF).
    Files are read here, on the client: the workers need not see them.
    """
    if isinstance(model, tuple) and len(model) == 2 and model[0] in ("id", "urdf"):
        return model
    if isinstance(model, RobotModel):
        raise KinematicsError("give the model as a catalogue id or a URDF/DH file: a RobotModel object is not "
                              "shipped to workers")
    if isinstance(model, str):
        if model.lower().endswith(".urdf") or os.path.sep in model:
            urdf = model
        else:
            model_id = model
    if model_id is not None:
        return ("id", model_id)
    if urdf is not None:
        with open(urdf, encoding="utf-8") as fh:
            return ("urdf", fh.read())
    if dh is not None:
        return ("urdf", table_to_urdf(load_table(dh)))
    raise KinematicsError("name a model: a catalogue id, a URDF file or a DH table file")


def worker_model(spec: tuple[str, str]) -> RobotModel:
    """The model of ``spec``, loaded and compiled once per process (then cached)."""
    key = spec[0] + ":" + (spec[1] if spec[0] == "id" else hashlib.sha256(spec[1].encode()).hexdigest())
    model = _cache.get(key)
    if model is not None:
        return model
    with _lock:
        model = _cache.get(key)
        if model is None:
            model = api.load_model(model_id=spec[1]) if spec[0] == "id" else parse_urdf(spec[1])
            getattr(compile_model(model), "kernel", None)  # compiled here, once: every partition reuses it
            LOADS["count"] += 1
            _cache[key] = model
    return model


def _labels(model: RobotModel, kind: str, links, link):
    if kind == "fk":
        return api.resolve_links(model, links)
    return list(model.joint_names)


def _empty_result(kind: str, labels) -> dict[str, np.ndarray]:
    L = len(labels)
    chunk = np.empty((0, L, 4, 4)) if kind == "fk" else np.empty((0, 6, L))
    return result_columns(kind, chunk, labels)


def compute_partition(df, spec, kind: str = "fk", links=None, link: str | None = None, reference: str = "world",
                      time_column: str | None = TIME_COLUMN, threads: int = 1):
    """The output columns (a pandas DataFrame, same index) of one partition ``df`` of joint
    columns: FK of ``links`` or the Jacobian of ``link`` in ``reference``, with ``time_column``
    carried first when the partition has it."""
    import pandas as pd

    model = worker_model(spec)
    labels = _labels(model, kind, links, link)
    missing = [j for j in model.joint_names if j not in df.columns]
    if missing:
        raise KinematicsError(f"no column for joint(s) {', '.join(missing)}")
    Q = np.ascontiguousarray(df[list(model.joint_names)].to_numpy(dtype=np.float64))
    if Q.shape[0] == 0:
        cols = _empty_result(kind, labels)
    else:
        with _threads(threads):
            if kind == "fk":
                result = api.fk(model, Q, links=labels).poses
            else:
                result = api.jacobian(model, Q, link=link, reference=reference).jacobians
        cols = result_columns(kind, result, labels)
    out = pd.DataFrame(cols, index=df.index, copy=False)
    if time_column is not None and time_column in df.columns:
        out.insert(0, time_column, df[time_column])
    return out


def _map(ddf, spec, kind, links, link, reference, time_column, threads):
    import pandas as pd

    model = worker_model(spec)  # on the client too: validates the links and gives the columns
    labels = _labels(model, kind, links, link)
    if kind == "jacobian":
        link = model.leaf_links[0] if link is None else link
        api.resolve_links(model, [link])
    missing = [j for j in model.joint_names if j not in ddf.columns]
    if missing:
        raise KinematicsError(f"the dataframe has no column for joint(s) {', '.join(missing)}")
    meta = pd.DataFrame(_empty_result(kind, labels))
    if time_column is not None and time_column in ddf.columns:
        meta.insert(0, time_column, ddf._meta[time_column])
    return ddf.map_partitions(compute_partition, spec, kind, labels if kind == "fk" else None, link, reference,
                              time_column, threads, meta=meta)


def fk_dask(ddf, model, links: Sequence[str] | str | None = None, time_column: str | None = TIME_COLUMN,
            threads: int = 1):
    """FK of ``links`` (None: the leaf links; ``"all"``; names) for every row of the Dask dataframe
    ``ddf`` (joint columns by name): a lazy Dask dataframe of ``<link>.x, ..., <link>.qz`` columns
    (``time_column`` first when ``ddf`` has it), one partition per input partition. ``model``: as
    :func:`model_spec` (a catalogue id, a URDF file, or a spec)."""
    return _map(ddf, model_spec(model), "fk", links, None, "world", time_column, threads)


def jacobian_dask(ddf, model, link: str | None = None, reference: str = "world",
                  time_column: str | None = TIME_COLUMN, threads: int = 1):
    """Jacobians of ``link`` in ``reference`` for every row of ``ddf``: a lazy Dask dataframe of
    ``J<r><c>`` columns (as :func:`fk_dask`)."""
    return _map(ddf, model_spec(model), "jacobian", None, link, reference, time_column, threads)


#: default target size of a partition (uncompressed): small enough to balance the workers
DEFAULT_BLOCKSIZE = "32MiB"


def read_joint_parquet(source, model, time_column: str | None = TIME_COLUMN, blocksize: str | int | None = DEFAULT_BLOCKSIZE):
    """A Dask dataframe of the joint columns (and the time column) of a Parquet file, directory or
    glob, split into partitions by row groups (``blocksize``: Dask's target partition size)."""
    model = worker_model(model_spec(model))
    return read_parquet_columns(source, list(model.joint_names), time_column, blocksize)


def read_parquet_columns(source, columns: Sequence[str], time_column: str | None = TIME_COLUMN,
                         blocksize: str | int | None = DEFAULT_BLOCKSIZE):
    """A Dask dataframe of ``columns`` (and the time column, first, when the files have it) of a
    Parquet file, directory or glob, split into partitions by row groups (``blocksize``)."""
    dd = _dask()
    cols = list(columns)
    import pyarrow.parquet as pq

    from .io.parquet import parquet_files

    names = pq.ParquetFile(parquet_files(source)[0]).schema_arrow.names
    if time_column is not None and time_column in names:
        cols = [time_column] + cols
    kw = {} if blocksize is None else {"blocksize": blocksize}
    return dd.read_parquet(str(source), columns=cols, split_row_groups="adaptive", **kw)


def connect(address: str):
    """A ``dask.distributed`` client: ``local:N`` starts a LocalCluster of N worker processes (one
    thread each); anything else is a scheduler address (``tcp://host:8786``)."""
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:  # pragma: no cover - the `dask` extra
        raise KinematicsError("distributed runs need dask: pip install 'kinematics-service[dask]'") from None
    if address.startswith("local"):
        n = address.partition(":")[2] or str(os.cpu_count() or 1)
        try:
            workers = int(n)
        except ValueError:
            raise KinematicsError(f"--dask local:N needs a number of workers, got {address!r}") from None
        if workers < 1:
            raise KinematicsError("--dask local:N needs at least one worker")
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
        client._kinematics_cluster = cluster
        return client
    return Client(address)


def _one_core_per_thread() -> None:
    """On a worker: pyarrow's decoding threads as many as the worker's task threads (by default
    pyarrow uses every core in every worker process, and the workers of a machine fight over them)."""
    try:
        from distributed import get_worker

        n = get_worker().state.nthreads
    except (ImportError, ValueError, AttributeError):
        return
    import pyarrow

    pyarrow.set_cpu_count(max(1, int(n)))


def warm_up(client, spec: tuple[str, str]) -> dict:
    """Load and compile the model on every worker of ``client`` now (in parallel), so that the
    first partitions do not wait for it: ``{worker: loads so far}``."""
    def load(spec=spec):
        _one_core_per_thread()
        worker_model(spec)
        return LOADS["count"]

    return client.run(load)


@dataclass(frozen=True)
class CollisionTask:
    """What a self-collision partition needs besides its rows: the matrix's ``samples`` and
    ``cache_dir`` (a directory the workers share computes it once), ``margin`` (m), the user's
    ``pairs`` (:class:`~kinematics.algorithms.collision_matrix.UserPairs` or None) and ``chunk``
    (rows checked at once)."""

    samples: int = 10_000
    margin: float = 0.0
    cache_dir: str | None = None
    pairs: Any = None
    chunk: int = 65_536


#: the output columns of a self-collision partition
COLLISION_COLUMNS = ("colliding", "pairs")


def collision_columns(answer) -> dict[str, np.ndarray]:
    """``colliding`` (bool) and ``pairs`` (``a|b;c|d``) of a :class:`~kinematics.usecases.CollisionAnswer`."""
    return {"colliding": np.asarray(answer.colliding, dtype=bool),
            "pairs": np.array([";".join(f"{a}|{b}" for a, b in row) for row in answer.pairs], dtype=object)}


def collision_partition(df, spec, task: CollisionTask, time_column: str | None = TIME_COLUMN):
    """``colliding`` and ``pairs`` (a pandas DataFrame, same index) of one partition ``df`` of joint
    columns, checked in slices of ``task.chunk`` rows; ``time_column`` carried first."""
    import pandas as pd

    model = worker_model(spec)
    missing = [j for j in model.joint_names if j not in df.columns]
    if missing:
        raise KinematicsError(f"no column for joint(s) {', '.join(missing)}")
    Q = np.ascontiguousarray(df[list(model.joint_names)].to_numpy(dtype=np.float64))
    colliding, pairs = np.zeros(len(Q), dtype=bool), np.empty(len(Q), dtype=object)
    for start in range(0, len(Q), task.chunk):
        a = api.collision(model, Q[start:start + task.chunk], margin=task.margin, samples=task.samples,
                          cache_dir=task.cache_dir, collision_pairs=task.pairs)
        cols = collision_columns(a)
        colliding[start:start + len(a.colliding)] = cols["colliding"]
        pairs[start:start + len(a.colliding)] = cols["pairs"]
    out = pd.DataFrame({"colliding": colliding, "pairs": pd.array(pairs, dtype="string")}, index=df.index, copy=False)
    if time_column is not None and time_column in df.columns:
        out.insert(0, time_column, df[time_column])
    return out


def collision_dask(ddf, model, task: CollisionTask = CollisionTask(), time_column: str | None = TIME_COLUMN):
    """Self-collision of every row of the Dask dataframe ``ddf`` (joint columns by name): a lazy
    Dask dataframe of ``colliding``, ``pairs`` (``time_column`` first when ``ddf`` has it), one
    partition per input partition. The pairs' names are checked here, on the client."""
    import pandas as pd

    spec = model_spec(model)
    m = worker_model(spec)
    api.collision_matrix(m, task.samples, cache_dir=task.cache_dir, collision_pairs=task.pairs)
    missing = [j for j in m.joint_names if j not in ddf.columns]
    if missing:
        raise KinematicsError(f"the dataframe has no column for joint(s) {', '.join(missing)}")
    meta = pd.DataFrame({"colliding": np.zeros(0, bool), "pairs": pd.array([], dtype="string")})
    if time_column is not None and time_column in ddf.columns:
        meta.insert(0, time_column, ddf._meta[time_column])
    return ddf.map_partitions(collision_partition, spec, task, time_column, meta=meta)


def run_parquet(source, dest, model, kind: str = "fk", links=None, link=None, reference: str = "world",
                address: str = "local", time_column: str | None = TIME_COLUMN, blocksize=DEFAULT_BLOCKSIZE,
                collision: CollisionTask | None = None) -> int:
    """Read ``source`` (Parquet), compute on the Dask cluster at ``address`` (:func:`connect`), write
    the partitioned Parquet dataset ``dest`` (a directory, one file per partition); the row count.
    ``kind``: ``fk``, ``jacobian`` or ``collision`` (with ``collision``, its :class:`CollisionTask`)."""
    spec = model_spec(model)
    client = connect(address)
    try:
        warm_up(client, spec)
        ddf = read_joint_parquet(source, spec, time_column, blocksize)
        mapped = (collision_dask(ddf, spec, collision or CollisionTask(), time_column) if kind == "collision"
                  else _map(ddf, spec, kind, links, link, reference, time_column, 1))
        mapped.to_parquet(str(dest), write_index=False, **WRITE_OPTIONS)
        return int(sum(f.metadata.num_rows for f in _files(dest)))
    finally:
        close(client)


def close(client) -> None:
    """Close a client of :func:`connect`, and the LocalCluster it started."""
    cluster = getattr(client, "_kinematics_cluster", None)
    client.close()
    if cluster is not None:
        cluster.close()


def _files(dest):
    import pyarrow.parquet as pq

    from .io.parquet import parquet_files

    return [pq.ParquetFile(f) for f in parquet_files(dest)]


# ---------------------------------------------------------------------- trajectories of many paths
#: the column naming the path of each waypoint row in a Parquet dataset of paths
PATH_COLUMN = "path"


@dataclass(frozen=True)
class TrajectoryTask:
    """What a partition of paths needs besides its rows: the :class:`~kinematics.usecases.TrajectoryLimits`,
    the ``interpolation``, ``blend`` and ``rate`` of :func:`kinematics.trajectory`, and the name of the
    path id column (``path_column``)."""

    limits: Any
    interpolation: str = "spline"
    blend: float = 0.0
    rate: float = 100.0
    path_column: str = PATH_COLUMN


def trajectory_columns(joint_names: Sequence[str]) -> list[str]:
    """The sample columns of a trajectory table: ``t``, then ``q_<joint>``, ``qd_<joint>``, ``qdd_<joint>``
    (the order of the local command's CSV)."""
    return ["t"] + [f"{p}_{n}" for p in ("q", "qd", "qdd") for n in joint_names]


def trajectory_partition(df, spec, task: TrajectoryTask):
    """The trajectories (a pandas DataFrame: the path id column, then :func:`trajectory_columns`) of the
    paths in ``df``: each path id's rows, in their order, are its waypoints (joint columns by name);
    paths in the order of their first row. A local run and a Dask run call this on the same tables."""
    import pandas as pd

    from .usecases import Query, trajectory

    model = worker_model(spec)
    missing = [c for c in (task.path_column, *model.joint_names) if c not in df.columns]
    if missing:
        raise KinematicsError(f"no column {', '.join(missing)} in the dataset of paths")
    names = trajectory_columns(model.joint_names)
    query, frames = Query(model), []
    for pid, rows in df.groupby(task.path_column, sort=False):
        W = rows[list(model.joint_names)].to_numpy(dtype=np.float64)
        try:
            a = trajectory(query, W, task.limits, interpolation=task.interpolation, blend=task.blend, rate=task.rate)
        except KinematicsError as exc:
            raise type(exc)(f"path {pid}: {exc}") from None
        frame = pd.DataFrame(np.column_stack([a.t, a.q, a.qd, a.qdd]), columns=names)
        frame.insert(0, task.path_column, pd.Series([pid] * len(a.t), dtype=df[task.path_column].dtype))
        frames.append(frame)
    if not frames:
        empty = pd.DataFrame({n: np.zeros(0) for n in names})
        empty.insert(0, task.path_column, pd.Series([], dtype=df[task.path_column].dtype))
        return empty
    return pd.concat(frames, ignore_index=True)


def check_paths_apart(ids_per_part) -> None:
    """Refuse a path id found in two files (partitions): each path must lie in one file."""
    seen: dict[Any, int] = {}
    for k, ids in enumerate(ids_per_part):
        for pid in ids:
            if seen.setdefault(pid, k) != k:
                raise KinematicsError(f"path {pid} has rows in two files of the dataset; keep each path in one file")


def run_parquet_trajectories(source, dest, model, task: TrajectoryTask, address: str = "local") -> int:
    """The trajectory of every path of the Parquet dataset ``source`` (one partition per file) on the Dask
    cluster at ``address``, written as the Parquet dataset ``dest`` (one file per input file); the
    number of paths."""
    spec = model_spec(model)
    m = worker_model(spec)
    client = connect(address)
    try:
        warm_up(client, spec)
        dd = _dask()
        ddf = dd.read_parquet(str(source), columns=[task.path_column, *m.joint_names], split_row_groups=False)
        ids = ddf[task.path_column].map_partitions(lambda s: s.drop_duplicates(), meta=ddf._meta[task.path_column])
        parts = [p.tolist() for p in client.compute(ids.to_delayed(), sync=True)]
        check_paths_apart(parts)
        meta = trajectory_partition(ddf._meta, spec, task)
        ddf.map_partitions(trajectory_partition, spec, task, meta=meta).to_parquet(str(dest), write_index=False,
                                                                                  **WRITE_OPTIONS)
        return sum(len(p) for p in parts)
    finally:
        close(client)


# ---------------------------------------------------------------------- every IK solution of many targets
@dataclass(frozen=True)
class IKAllTask:
    """What a partition of target poses needs besides its rows: the ``link`` placed at them, the
    :class:`~kinematics.usecases.ik_options.IKOptions` of the run (solution set ``all``), the ``seed``
    (or None), the user's ``collision_pairs`` (or None), the target ``columns`` (``x, y, z, qw, qx, qy,
    qz``, a prefix allowed) and ``chunk``: targets solved at once, so that a worker holds one partition
    of targets, one chunk's solver state and the partition's solutions, whatever the dataset's length."""

    link: str
    options: Any
    columns: tuple[str, ...]
    seed: Any = None
    collision_pairs: Any = None
    chunk: int = 4096


def ik_all_columns(joint_names: Sequence[str]) -> list[str]:
    """The columns of every-solution rows: ``target`` (0-based, across the dataset), the joints,
    ``position_error``, ``rotation_error``, ``within_limits``, ``singular`` (the local command's CSV)."""
    return ["target", *joint_names, "position_error", "rotation_error", "within_limits", "singular"]


def ik_all_rows(answer, start: int) -> dict[str, np.ndarray]:
    """The rows of every solution of an :class:`~kinematics.usecases.IKAllAnswer`, target by target
    and each target's in the answer's order (as the local command writes them), the targets
    numbered from ``start``."""
    K = answer.q.shape[1]
    n, k = np.nonzero(np.arange(K)[None, :] < np.asarray(answer.count)[:, None])
    q = answer.q[n, k]
    cols: dict[str, np.ndarray] = {"target": (start + n).astype(np.int64)}
    cols.update({name: np.ascontiguousarray(q[:, j]) for j, name in enumerate(answer.joint_names)})
    cols["position_error"], cols["rotation_error"] = answer.position_error[n, k], answer.rotation_error[n, k]
    cols["within_limits"], cols["singular"] = answer.within_limits[n, k], answer.singular[n, k]
    return cols


def ik_all_partition(df, spec, task: IKAllTask, offsets: Sequence[int] = (0,), time_column: str | None = TIME_COLUMN,
                     partition_info=None):
    """Every solution (a pandas DataFrame of :func:`ik_all_columns`, the target's time first when ``df``
    has the time column) of the targets of one partition ``df``; ``offsets[i]``: the index of
    partition i's first target in the dataset (Dask passes ``partition_info``)."""
    import pandas as pd

    from .io.parquet import check_unit_quaternions, pose_matrices
    from .usecases import Query

    model = worker_model(spec)
    start = int(offsets[partition_info["number"]]) if partition_info else int(offsets[0])
    A = df[list(task.columns)].to_numpy(dtype=np.float64)
    check_unit_quaternions(A, "targets", start, task.columns)
    T = pose_matrices(A)
    names = ik_all_columns(model.joint_names)
    times = df[time_column].to_numpy() if time_column is not None and time_column in df.columns else None
    query = Query(model, link=task.link, collision_pairs=task.collision_pairs)
    frames = []
    for s in range(0, len(T), task.chunk):
        cols = ik_all_rows(api.ik(query, T[s:s + task.chunk], seed=task.seed, options=task.options), start + s)
        frame = pd.DataFrame(cols, columns=names)
        if times is not None:
            frame.insert(0, time_column, times[cols["target"] - start])
        frames.append(frame)
    if frames:
        return pd.concat(frames, ignore_index=True)
    empty = pd.DataFrame({"target": np.zeros(0, np.int64), **{n: np.zeros(0) for n in names[1:-2]},
                          "within_limits": np.zeros(0, bool), "singular": np.zeros(0, bool)}, columns=names)
    if times is not None:
        empty.insert(0, time_column, df[time_column].iloc[:0])
    return empty


def ik_all_dask(ddf, model, task: IKAllTask, time_column: str | None = TIME_COLUMN, lengths: Sequence[int] | None = None):
    """Every IK solution of every target pose (rows of ``task.columns``) of the Dask dataframe ``ddf``:
    a lazy Dask dataframe of :func:`ik_all_columns` (the time column first when ``ddf`` has it), one
    partition per input partition. ``lengths``: the partitions' row counts (counted here if not given:
    a pass over the partitions as they are, not a projection of them, which Dask may split otherwise),
    which number the targets across the dataset."""
    spec = model_spec(model)
    m = worker_model(spec)
    api.resolve_links(m, [task.link])
    missing = [c for c in task.columns if c not in ddf.columns]
    if missing:
        raise KinematicsError(f"the dataframe has no target column(s) {', '.join(missing)}")
    if lengths is None:
        lengths = ddf.map_partitions(len).compute().tolist()
    offsets = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(np.int64).tolist()
    meta = ik_all_partition(ddf._meta, spec, task, [0], time_column)
    return ddf.map_partitions(ik_all_partition, spec, task, offsets, time_column, meta=meta)


def part_name(i: int) -> str:
    """The file of partition ``i`` of an output dataset, numbered so that the names sort in the partitions'
    order (a reader of the directory gets the rows in the dataset's order)."""
    return f"part.{i:06d}.parquet"


def warm_up_ik(client, spec, task: IKAllTask) -> None:
    """Solve one target on every worker of ``client``: the model and the IK kernels ready before the run."""
    def solve(spec=spec, task=task):
        from .usecases import Query

        model = worker_model(spec)
        T = api.fk(model, model.sample_configurations(1, np.random.default_rng(0)), links=[task.link]).poses[:, 0]
        api.ik(Query(model, link=task.link), T, options=task.options)

    client.run(solve)


def run_parquet_ik_all(source, dest, model, task: IKAllTask, address: str = "local",
                       time_column: str | None = TIME_COLUMN, blocksize=DEFAULT_BLOCKSIZE) -> tuple[int, int, int]:
    """Every IK solution of every target of the Parquet dataset ``source`` on the Dask cluster at
    ``address``, written as the Parquet dataset ``dest`` (one file per partition): ``(targets, solutions,
    targets with a solution)``."""
    spec = model_spec(model)
    client = connect(address)
    try:
        warm_up(client, spec)
        warm_up_ik(client, spec, task)
        ddf = read_parquet_columns(source, task.columns, time_column, blocksize)
        lengths = client.compute(ddf.map_partitions(len), sync=True).tolist()
        mapped = ik_all_dask(ddf, spec, task, time_column, lengths)
        mapped.to_parquet(str(dest), write_index=False, name_function=part_name, **WRITE_OPTIONS)
        files = _files(dest)  # a target's solutions are in one file: count them file by file
        solved = sum(len(np.unique(f.read(columns=["target"]).column(0).to_numpy())) for f in files)
        return int(sum(lengths)), int(sum(f.metadata.num_rows for f in files)), int(solved)
    finally:
        close(client)
