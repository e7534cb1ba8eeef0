"""Dask runs (kinematics/distributed.py, `kinematics fk --dask`): a LocalCluster of 2 worker
processes gives the local run's answer bit for bit, and each worker compiles the model once."""

from __future__ import annotations

import numpy as np
import pytest

dd = pytest.importorskip("dask.dataframe")
distributed_lib = pytest.importorskip("dask.distributed")
pq = pytest.importorskip("pyarrow.parquet")

from kinematics import compile_model, default_catalogue
from kinematics import distributed
from kinematics.cli import main
from tests.rosbag_files import write_joint_dataset

N_PER_FILE = (7000, 5000, 9001)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory, ur5):
    root = tmp_path_factory.mktemp("dask-data")
    return root, write_joint_dataset(root, ur5, N_PER_FILE, seed=17, row_group_size=2000)


@pytest.fixture(scope="module")
def cluster():
    with distributed_lib.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                      dashboard_address=None) as c, distributed_lib.Client(c) as client:
        yield client


def _columns(table, prefix):
    return np.stack([table.column(c).to_numpy() for c in table.column_names if c.startswith(prefix)], axis=1)


def test_cli_dask_local_2_equals_local_run(dataset, tmp_path):
    root, Q = dataset
    local = tmp_path / "local.parquet"
    out = tmp_path / "dask_out"
    assert main(["fk", "--model", "ur5", "--links", "tool0,wrist_1_link", str(root / "log"), "-o", str(local)]) == 0
    assert main(["fk", "--model", "ur5", "--links", "tool0,wrist_1_link", str(root / "log"), "--dask", "local:2",
                 "-o", str(out)]) == 0
    files = sorted(out.glob("*.parquet"), key=lambda p: int(p.stem.split(".")[1]))
    assert len(files) >= 2  # partitioned output
    got = dd.read_parquet(str(out)).compute()
    want = pq.read_table(local)
    assert list(got.columns) == want.column_names
    for name in want.column_names:
        assert np.array_equal(got[name].to_numpy(), want.column(name).to_numpy()), name
    assert got["time"].to_numpy().tolist() == list(range(len(Q)))


def test_library_fk_and_jacobian_on_a_cluster(dataset, cluster, ur5):
    root, Q = dataset
    poe = compile_model(ur5)
    ddf = dd.read_parquet(str(root / "log"), split_row_groups=True)
    assert ddf.npartitions > 2
    poses = distributed.fk_dask(ddf, "ur5", links=["tool0"]).compute()
    T = poe.fk(Q, ["tool0"])[:, 0]
    assert np.array_equal(poses[["tool0.x", "tool0.y", "tool0.z"]].to_numpy(), T[:, :3, 3])
    J = distributed.jacobian_dask(ddf, "ur5", link="tool0", reference="local").compute()
    assert np.array_equal(J[[f"J{r}{c}" for r in range(6) for c in range(6)]].to_numpy().reshape(-1, 6, 6),
                          poe.jacobian(Q, "tool0", "local"))
    # every worker loaded (compiled) the model once, whatever the number of partitions it took
    loads = cluster.run(lambda: __import__("kinematics.distributed").distributed.LOADS["count"])
    assert set(loads.values()) <= {0, 1} and sum(loads.values()) >= 1


def test_usage_errors(dataset, tmp_path, capsys):
    root, _ = dataset
    csv = tmp_path / "q.csv"
    csv.write_text("0,0,0,0,0,0\n")
    assert main(["fk", "--model", "ur5", str(csv), "--dask", "local:1", "-o", str(tmp_path / "o")]) == 2
    assert "--dask reads a Parquet INPUT" in capsys.readouterr().err
    assert main(["fk", "--model", "ur5", str(root / "log"), "--dask", "local:1"]) == 2
    with pytest.raises(Exception, match="catalogue id or a URDF"):
        distributed.model_spec(default_catalogue().get("ur5"))
