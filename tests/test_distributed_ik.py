"""Every IK solution on Dask (kinematics/distributed.py ``ik_all_dask``, ``kinematics ik --all --dask``):
the rows of the local command, partition by partition, targets numbered across the dataset."""

from __future__ import annotations

import numpy as np
import pytest

dd = pytest.importorskip("dask.dataframe")
pq = pytest.importorskip("pyarrow.parquet")

from kinematics import distributed
from kinematics.cli import main
from kinematics.io.parquet import ParquetTargetRows
from kinematics.usecases import Query, ik
from kinematics.usecases.ik_options import IKOptions, SolutionSet
from tests.rosbag_files import write_target_dataset

LINK = "tool0"
COLUMNS = tuple(f"{LINK}.{c}" for c in ("x", "y", "z", "qw", "qx", "qy", "qz"))
OPTIONS = IKOptions(solutions=SolutionSet("all", solution_limits="ignore"))


@pytest.fixture(scope="module")
def dataset(tmp_path_factory, ur5):
    root = tmp_path_factory.mktemp("dask-ik")
    return root, write_target_dataset(root, ur5, LINK, (130, 71), seed=29, row_group_size=50)


def test_the_library_equals_a_local_solve(dataset, ur5):
    root, T = dataset
    ddf = distributed.read_parquet_columns(root / "targets", COLUMNS, blocksize=None)
    assert ddf.npartitions >= 2
    task = distributed.IKAllTask(LINK, OPTIONS, COLUMNS, chunk=17)  # chunks smaller than a partition
    got = distributed.ik_all_dask(ddf, "ur5", task).compute(scheduler="synchronous")
    with ParquetTargetRows(root / "targets") as rows:  # the targets as the local command reads them
        read = np.concatenate([chunk for _, chunk in rows])
    assert np.abs(read - T).max() < 1e-12
    local = ik(Query(ur5, link=LINK), read, options=OPTIONS)
    want = distributed.ik_all_rows(local, 0)
    assert list(got.columns) == ["time"] + distributed.ik_all_columns(ur5.joint_names)
    assert len(got) == int(local.count.sum()) > 4 * len(T)  # several solutions a target
    for name, column in want.items():
        assert np.array_equal(got[name].to_numpy(), column), name
    assert np.array_equal(got["time"].to_numpy(), got["target"].to_numpy())  # the dataset's time numbers the rows


def test_rows_are_the_records_of_the_answer(ur5):
    T = ur5.sample_configurations(3, np.random.default_rng(2))
    from kinematics import fk

    a = ik(Query(ur5, link=LINK), fk(ur5, T, links=[LINK]).poses[:, 0], options=OPTIONS)
    rows = distributed.ik_all_rows(a, 10)
    records = [(10 + n, rec) for n in range(3) for rec in a.solutions(n)]
    assert rows["target"].tolist() == [n for n, _ in records]
    assert rows["shoulder_pan_joint"].tolist() == [rec["q"][0] for _, rec in records]
    assert rows["within_limits"].tolist() == [rec["within_limits"] for _, rec in records]


def test_the_command_refuses_what_dask_cannot_do(dataset, tmp_path, capsys):
    root, _ = dataset
    assert main(["ik", "--model", "ur5", "--link", LINK, str(root / "targets"), "--dask", "local:1",
                 "-o", str(tmp_path / "o")]) == 2
    assert "--dask needs --all" in capsys.readouterr().err
    csv = tmp_path / "t.csv"
    csv.write_text("x,y,z,qw,qx,qy,qz\n0.4,0.1,0.3,1,0,0,0\n")
    assert main(["ik", "--model", "ur5", "--link", LINK, "--all", str(csv), "--dask", "local:1",
                 "-o", str(tmp_path / "o")]) == 2
    assert "--dask reads a Parquet INPUT" in capsys.readouterr().err


@pytest.mark.slow
def test_cli_dask_local_2_equals_the_local_command(dataset, tmp_path):
    import pandas as pd

    root, _ = dataset
    common = ["ik", "--model", "ur5", "--link", LINK, "--all", "--limits", "ignore", str(root / "targets")]
    assert main([*common, "-o", str(tmp_path / "local.csv")]) == 0
    assert main([*common, "--dask", "local:2", "-o", str(tmp_path / "out")]) == 0
    table = pq.read_table(tmp_path / "out").to_pandas()
    local = pd.read_csv(tmp_path / "local.csv")
    assert list(table.columns) == ["time", *local.columns]
    for name in local.columns:
        assert np.array_equal(table[name].to_numpy(), local[name].to_numpy()), name
