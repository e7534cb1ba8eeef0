"""Self-collision on Dask (kinematics/distributed.py ``collision_dask``, ``kinematics collision
--dask``): the same answers as the local command, partition by partition, in bounded slices."""

from __future__ import annotations

import csv

import numpy as np
import pytest

dd = pytest.importorskip("dask.dataframe")
pq = pytest.importorskip("pyarrow.parquet")

from kinematics import UserPairs, collision
from kinematics import distributed
from kinematics.cli import main
from tests.rosbag_files import write_joint_dataset

SAMPLES = 300
PAIRS = UserPairs(allow=[("base_link", "upper_arm_link")], forbid=[("wrist_1_link", "wrist_3_link")])


@pytest.fixture(scope="module")
def dataset(tmp_path_factory, ur5):
    root = tmp_path_factory.mktemp("dask-collision")
    return root, write_joint_dataset(root, ur5, (700, 501), seed=23, row_group_size=200)


def _joined(answer):
    return [";".join(f"{a}|{b}" for a, b in row) for row in answer.pairs]


def test_the_library_equals_a_local_check(dataset, ur5):
    root, Q = dataset
    ddf = distributed.read_joint_parquet(root / "log", "ur5", blocksize=None)
    assert ddf.npartitions >= 2
    task = distributed.CollisionTask(samples=SAMPLES, pairs=PAIRS, chunk=97)  # slices smaller than a partition
    got = distributed.collision_dask(ddf, "ur5", task).compute(scheduler="synchronous")
    local = collision(ur5, Q, samples=SAMPLES, collision_pairs=PAIRS)
    assert list(got.columns) == ["time", "colliding", "pairs"]
    assert got["time"].tolist() == list(range(len(Q)))
    assert got["colliding"].tolist() == local.colliding.tolist()
    assert got["pairs"].tolist() == _joined(local)
    assert 0 < local.colliding.sum() < len(Q)
    with pytest.raises(Exception, match="nope_link"):
        distributed.collision_dask(ddf, "ur5", distributed.CollisionTask(samples=SAMPLES,
                                                                         pairs=UserPairs(allow=[("nope_link", "base_link")])))


@pytest.mark.slow
def test_cli_dask_local_2_equals_the_local_command(dataset, tmp_path):
    root, Q = dataset
    pairs = ["--allow", "base_link,upper_arm_link", "--forbid", "wrist_1_link,wrist_3_link", "-n", str(SAMPLES)]
    assert main(["collision", "--model", "ur5", str(root / "log"), "-o", str(tmp_path / "local.csv"), *pairs]) == 0
    assert main(["collision", "--model", "ur5", str(root / "log"), "--dask", "local:2", "-o", str(tmp_path / "out"),
                 *pairs]) == 0
    table = pq.read_table(tmp_path / "out").sort_by("time")
    rows = list(csv.DictReader((tmp_path / "local.csv").open()))
    assert table.column("colliding").to_pylist() == [bool(int(r["colliding"])) for r in rows]
    assert table.column("pairs").to_pylist() == [r["pairs"] for r in rows]


def test_usage_errors(dataset, tmp_path, capsys):
    root, _ = dataset
    csv_in = tmp_path / "q.csv"
    csv_in.write_text("0,0,0,0,0,0\n")
    assert main(["collision", "--model", "ur5", str(csv_in), "--dask", "local:1", "-o", str(tmp_path / "o")]) == 2
    assert main(["collision", "--model", "ur5", str(root / "log"), "--dask", "local:1"]) == 2
    assert main(["collision", "--model", "ur5", str(root / "log"), "--dask", "local:1", "--distance",
                 "-o", str(tmp_path / "o")]) == 2
    assert "--dask" in capsys.readouterr().err
