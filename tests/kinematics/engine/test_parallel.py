"""Batches split over threads (kinematics/engine/parallel.py) give the one-thread answer bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import api, compile_model
from kinematics.engine import parallel, plans
from kinematics.errors import KinematicsError
from kinematics.spatial.reference import REFERENCES


@pytest.fixture
def small_splits(monkeypatch):
    """Split batches of a few hundred rows already (the real threshold is thousands)."""
    monkeypatch.setattr(plans, "FK_MIN_ROWS", 64)


@pytest.mark.parametrize("model_id", ["ur5", "panda", "talos_reduced"])
def test_fk_and_jacobians_bit_identical_over_threads(catalogue, small_splits, model_id):
    model = catalogue.get(model_id)
    poe = compile_model(model)
    Q = model.sample_configurations(1001, np.random.default_rng(11))  # not a multiple of the chunk
    leaf = model.leaf_links[-1]
    with parallel.threads(1):
        T1 = poe.fk(Q).copy()
        J1 = {r: poe.jacobian(Q, leaf, r).copy() for r in REFERENCES}
    for n in (2, 3, 5):
        with parallel.threads(n):
            assert np.array_equal(poe.fk(Q), T1)
            for r in REFERENCES:
                assert np.array_equal(poe.jacobian(Q, leaf, r), J1[r])


def test_split_really_uses_threads(monkeypatch):
    calls = []
    used = parallel.run_rows(lambda a, b: calls.append((a, b)), 1000, min_rows=100, align=256, n_threads=3)
    assert used == 2 and sorted(calls) == [(0, 512), (512, 1000)]  # ranges start on chunk boundaries
    calls.clear()
    assert parallel.run_rows(lambda a, b: calls.append((a, b)), 10, min_rows=4, piece_rows=3, n_threads=2) == 2
    assert sorted(calls) == [(0, 3), (3, 6), (6, 9), (9, 10)]
    assert parallel.run_rows(lambda a, b: calls.append((a, b)), 50, min_rows=100, n_threads=8) == 1  # too small


def test_errors_in_a_thread_are_raised():
    def boom(a, b):
        if a > 0:
            raise ValueError("piece")

    with pytest.raises(ValueError, match="piece"):
        parallel.run_rows(boom, 100, min_rows=10, n_threads=2)
    with pytest.raises(ValueError, match="piece"):
        parallel.run_rows(boom, 100, min_rows=10, piece_rows=10, n_threads=2)


def test_ik_bit_identical_over_threads(catalogue):
    model = catalogue.get("ur5")
    poe = compile_model(model)
    Q = model.sample_configurations(40, np.random.default_rng(12))
    T = poe.fk(Q, ["tool0"])[:, 0].copy()
    with parallel.threads(1):
        one = api.ik(model, T, link="tool0").solution
    with parallel.threads(2):
        two = api.ik(model, T, link="tool0").solution
    assert np.array_equal(one.q, two.q)
    assert np.array_equal(one.position_error, two.position_error)
    assert np.array_equal(one.iterations, two.iterations)
    assert np.array_equal(one.success, two.success)


def test_thread_count_settings(monkeypatch):
    monkeypatch.delenv(parallel.ENV_THREADS, raising=False)
    assert parallel.thread_count() == parallel.available_cores()
    monkeypatch.setenv(parallel.ENV_THREADS, "3")
    assert parallel.thread_count() == 3
    parallel.set_threads(5)
    try:
        assert parallel.thread_count() == 5
        with parallel.threads(2):
            assert parallel.thread_count() == 2
        assert parallel.thread_count() == 5
    finally:
        parallel.set_threads(None)
    assert parallel.thread_count() == 3
    monkeypatch.setenv(parallel.ENV_THREADS, "zero")
    with pytest.raises(KinematicsError, match="KIN_THREADS"):
        parallel.thread_count()
    with pytest.raises(KinematicsError):
        parallel.set_threads(0)


def test_a_forked_child_gets_a_new_pool(catalogue, small_splits):
    import os

    model = catalogue.get("ur5")
    poe = compile_model(model)
    Q = model.sample_configurations(1000, np.random.default_rng(3))
    with parallel.threads(2):
        want = poe.fk(Q).copy()  # the parent's pool exists now
        pid = os.fork()
        if pid == 0:  # the child: the same batch on threads must not hang on the parent's dead pool
            ok = np.array_equal(poe.fk(Q), want)
            os._exit(0 if ok else 1)
        _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0
