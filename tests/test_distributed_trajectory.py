"""Trajectories of a Parquet dataset of paths (``kinematics trajectory`` with a ``path`` column,
locally and with ``--dask``): one trajectory per path id, the library's answer, the same on Dask."""

from __future__ import annotations

import numpy as np
import pytest

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

from kinematics import TrajectoryLimits, trajectory
from kinematics.cli import main

ARGS = ["--acceleration", "3", "--velocity", "1", "--rate", "40"]


def _path(k: int) -> np.ndarray:
    base = np.array([0.0, -1.57, 1.57, 0.0, 1.57, 0.0])
    return np.stack([base, base + 0.3 + 0.1 * k, base + [0.6, -0.2, 0.1, 0.3, -0.4, 0.5 * k]])


@pytest.fixture(scope="module")
def dataset(tmp_path_factory, ur5):
    root = tmp_path_factory.mktemp("dask-trajectory")
    (root / "paths").mkdir()
    names = list(ur5.joint_names)
    for f, ids in enumerate(((7, 3), (5,))):
        W = np.concatenate([_path(k) for k in ids])
        cols = {"path": pa.array(np.repeat(ids, 3).astype(np.int64))}
        cols.update({n: pa.array(W[:, j]) for j, n in reversed(list(enumerate(names)))})  # by name, any order
        pq.write_table(pa.table(cols), root / "paths" / f"part-{f}.parquet")
    return root


def _read(out):
    return pq.read_table(out).to_pandas()


def test_local_run_is_one_library_trajectory_per_path(dataset, tmp_path, ur5):
    assert main(["trajectory", "--model", "ur5", str(dataset / "paths"), "-o", str(tmp_path / "out"), *ARGS]) == 0
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["part.0.parquet", "part.1.parquet"]
    got = _read(tmp_path / "out")
    assert got["path"].drop_duplicates().tolist() == [7, 3, 5]  # file order, then first-row order
    names = list(ur5.joint_names)
    for k in (7, 3, 5):
        want = trajectory(ur5, _path(k), TrajectoryLimits(velocity=1.0, acceleration=3.0), rate=40)
        rows = got[got["path"] == k]
        np.testing.assert_array_equal(rows["t"].to_numpy(), want.t)
        for prefix, arr in (("q", want.q), ("qd", want.qd), ("qdd", want.qdd)):
            np.testing.assert_array_equal(rows[[f"{prefix}_{n}" for n in names]].to_numpy(), arr)


@pytest.mark.slow
def test_cli_dask_local_2_equals_the_local_command(dataset, tmp_path):
    assert main(["trajectory", "--model", "ur5", str(dataset / "paths"), "-o", str(tmp_path / "local"), *ARGS]) == 0
    assert main(["trajectory", "--model", "ur5", str(dataset / "paths"), "--dask", "local:2",
                 "-o", str(tmp_path / "dask"), *ARGS]) == 0
    local, dask = _read(tmp_path / "local"), _read(tmp_path / "dask")
    assert list(dask.columns) == list(local.columns) and len(dask) == len(local)
    for col in local.columns:
        np.testing.assert_array_equal(dask[col].to_numpy(), local[col].to_numpy())


def test_usage_errors(dataset, tmp_path, capsys, ur5):
    assert main(["trajectory", "--model", "ur5", str(dataset / "paths"), "-o", str(tmp_path / "o.npz"), *ARGS]) == 2
    csv_in = tmp_path / "w.csv"
    csv_in.write_text(",".join(ur5.joint_names) + "\n0,0,0,0,0,0\n0.1,0,0,0,0,0\n")
    assert main(["trajectory", "--model", "ur5", str(csv_in), "--dask", "local:1", "-o", str(tmp_path / "o"), *ARGS]) == 2
    # a path split over two files is refused, not timed in halves
    split = tmp_path / "split"
    split.mkdir()
    for f in range(2):
        pq.write_table(pa.table({"path": [1, 1], **{n: [0.1 * f, 0.2 * f] for n in ur5.joint_names}}),
                       split / f"p{f}.parquet")
    assert main(["trajectory", "--model", "ur5", str(split), "-o", str(tmp_path / "o2"), *ARGS]) == 2
    assert "two files" in capsys.readouterr().err
