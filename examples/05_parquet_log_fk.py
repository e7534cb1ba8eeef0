"""A Parquet log of joint states through FK: tool poses out, the time column carried along.

Writes a 100,000-row log of a UR5 (a time column and one column per joint, in any order),
streams it through the compiled FK in chunks (memory stays bounded at any length), writes the
poses to Parquet, and does the same with the command line. Needs the ``logs`` extra (pyarrow).

Run: python examples/05_parquet_log_fk.py
"""

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

import kinematics
from kinematics.io.parquet import ParquetJointRows, ParquetResultWriter

ur5 = kinematics.default_catalogue().get("ur5")
work = Path(tempfile.mkdtemp(prefix="kinematics-example-"))

# a log as a robot would record it: 1 kHz timestamps (ns), joints by name, columns in any order
N = 100_000
t = np.linspace(0.0, 2 * np.pi, N)
joints = {name: 0.5 * np.sin(t * (k + 1)) for k, name in enumerate(ur5.joint_names)}
log = pa.table({"time": np.arange(N, dtype=np.int64) * 1_000_000, **dict(reversed(joints.items()))})
pq.write_table(log, work / "joint_states.parquet")

# the library: read chunks by joint name, FK of tool0, one row group written per chunk
poe = kinematics.compile_model(ur5)
with ParquetJointRows(work / "joint_states.parquet", ur5, chunk_rows=20_000) as rows:
    with ParquetResultWriter(work / "poses.parquet", "fk", ["tool0"], time_field=rows.time_field) as out:
        for start, Q in rows:
            out.write(poe.fk(Q, ["tool0"]), rows.times)
poses = pq.read_table(work / "poses.parquet")
print(f"{poses.num_rows} rows, columns: {poses.column_names}")

# row k of the output is FK of row k of the log
k = 12_345
q = [joints[name][k] for name in ur5.joint_names]
expected = kinematics.fk(ur5, q, links=["tool0"]).poses[0, 0, :3, 3]
got = [poses.column(f"tool0.{c}")[k].as_py() for c in "xyz"]
print("row", k, "position:", np.round(got, 6), "matches FK:", bool(np.allclose(got, expected, atol=1e-15)))
print("time column carried:", poses.column("time").equals(log.column("time")))

# the same from the command line: kinematics fk --model ur5 --links tool0 LOG -o OUT
subprocess.run([sys.executable, "-m", "kinematics", "fk", "--model", "ur5", "--links", "tool0",
                str(work / "joint_states.parquet"), "-o", str(work / "poses_cli.parquet")], check=True)
cli = pq.read_table(work / "poses_cli.parquet")
print("command line output identical:", cli.equals(poses))
shutil.rmtree(work)
