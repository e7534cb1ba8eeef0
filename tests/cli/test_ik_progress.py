"""``kinematics ik`` on a terminal shows a bar that moves within a chunk (a chunk of 10,000 targets
is many seconds of IK), and writes the same answers as it does without one."""

from __future__ import annotations

import os
import re
import subprocess
import sys

import numpy as np

from kinematics import compile_model
from kinematics.cli.progress import BAR_STEP
from tests.paths import REPO

N = 3 * BAR_STEP


def test_the_ik_bar_moves_within_a_chunk_on_a_terminal(tmp_path, ur5):
    Q = ur5.sample_configurations(N, np.random.default_rng(5))
    np.save(tmp_path / "t.npy", compile_model(ur5).fk(Q, ["tool0"])[:, 0])
    env = {**os.environ, "PYTHONPATH": str(REPO), "COLUMNS": "120"}
    argv = [sys.executable, "-m", "kinematics", "ik", "--model", "ur5", "--link", "tool0", str(tmp_path / "t.npy")]
    leader, follower = os.openpty()  # stderr a terminal, as a person runs it
    try:
        proc = subprocess.run([*argv, "-o", str(tmp_path / "q.npy")], cwd=REPO, env=env, stdout=subprocess.DEVNULL,
                              stderr=follower, timeout=900)
        os.close(follower)
        err = b""
        while True:
            try:
                chunk = os.read(leader, 65536)
            except OSError:
                break
            if not chunk:
                break
            err += chunk
    finally:
        os.close(leader)
    assert proc.returncode == 0, err.decode(errors="replace")
    counts = {int(k) for k in re.findall(rb"ik:.*?\| *(\d+)/" + str(N).encode(), err)}
    assert {BAR_STEP, 2 * BAR_STEP} <= counts, err[-2000:]  # one chunk (default 10,000 rows), and the bar moved in it
    # the same answers as without a terminal (each target's answer is its own)
    piped = subprocess.run([*argv, "-o", str(tmp_path / "q_piped.npy")], cwd=REPO, env=env, capture_output=True,
                           timeout=900)
    assert piped.returncode == 0 and b"|" not in piped.stderr, piped.stderr
    np.testing.assert_array_equal(np.load(tmp_path / "q.npy"), np.load(tmp_path / "q_piped.npy"))
