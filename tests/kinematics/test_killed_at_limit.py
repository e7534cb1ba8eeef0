"""The computations that can run away run in a separate process that is killed at its limit:
closed forms (sympy, ``KIN_SYMBOLIC_TIMEOUT``) and xacro expansion (``RLIMIT_CPU`` of
``KIN_XACRO_CPU_SECONDS``, and a wall-clock limit). After the error no process of theirs is left."""

from __future__ import annotations

import time

import psutil
import pytest

from kinematics.algorithms import symbolic as sym
from kinematics.errors import ExpansionLimitError, SymbolicTimeoutError
from kinematics.io.catalogue import default_catalogue
from kinematics.io.xacro import SandboxLimits, expand_text
from tests.paths import REPO

CPU_BOMB = (REPO / "tests" / "corpus" / "descriptions" / "cpu_bomb.xacro").read_bytes()


def _descendants() -> set[int]:
    return {p.pid for p in psutil.Process().children(recursive=True) if p.status() != psutil.STATUS_ZOMBIE}


def test_symbolic_worker_is_killed_at_its_time_limit():
    panda = sym.chain_from_model(default_catalogue().get("panda"), "panda_hand_tcp")
    sym.derive(sym.chain_from_model(default_catalogue().get("planar_2r"), "tool"), timeout=60)  # the forkserver is up
    before = _descendants()
    t0 = time.monotonic()
    with pytest.raises(SymbolicTimeoutError):
        sym.derive(panda, what=("transforms", "jacobian"), simplify=True, timeout=0.5)
    assert time.monotonic() - t0 < 5.0  # the limit, plus the kill and join
    assert _descendants() <= before  # the worker is gone (the forkserver stays)


def test_xacro_expansion_is_killed_at_its_cpu_limit():
    before = _descendants()
    t0 = time.process_time(), time.monotonic()
    with pytest.raises(ExpansionLimitError, match="CPU time limit"):
        expand_text(CPU_BOMB, limits=SandboxLimits(cpu_seconds=1, wall_seconds=60))
    assert time.monotonic() - t0[1] < 10.0
    assert _descendants() <= before


def test_xacro_expansion_is_killed_at_its_wall_clock_limit():
    before = _descendants()
    t0 = time.monotonic()
    with pytest.raises(ExpansionLimitError, match="took longer than 1 s"):
        expand_text(CPU_BOMB, limits=SandboxLimits(cpu_seconds=100, wall_seconds=1))
    assert time.monotonic() - t0 < 6.0
    assert _descendants() <= before


def test_symbolic_worker_is_killed_when_its_caller_cancels():
    """A server cancels the token when its client disconnects: the worker goes at once, not at its limit."""
    import threading

    from kinematics import api
    from kinematics.errors import CancelledError

    panda = sym.chain_from_model(default_catalogue().get("panda"), "panda_hand_tcp")
    sym.derive(sym.chain_from_model(default_catalogue().get("planar_2r"), "tool"), timeout=60)
    before = _descendants()
    token = api.Cancellation()
    threading.Timer(0.3, token.cancel, args=("the client disconnected",)).start()
    t0 = time.monotonic()
    with api.cancellable(token), pytest.raises(CancelledError, match="the client disconnected"):
        sym.derive(panda, what=("transforms", "jacobian"), simplify=True, timeout=600)
    assert time.monotonic() - t0 < 10.0  # far under its limit of 600 s
    assert _descendants() <= before
