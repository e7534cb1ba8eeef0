"""Shared helpers of the benchmarks: machine info, interleaved timing, markdown tables."""

from __future__ import annotations

import os
import platform
import time
from dataclasses import dataclass, field
from datetime import datetime, timezone
from typing import Callable

import numpy as np

#: Robots of the headline tables (catalogue ids).
ROBOTS = ("ur5", "panda", "talos_reduced")
#: Link whose Jacobian / single FKinSpace is measured, when not simply the deepest leaf.
TOOL_LINKS = {"ur5": "tool0", "panda": "panda_hand_tcp"}
#: Seed of every random batch of configurations.
SEED = 20261122


def tool_link(model) -> str:
    """The benchmark's end effector: ``TOOL_LINKS`` or the leaf with the most moving joints above it."""
    if model.name in TOOL_LINKS and TOOL_LINKS[model.name] in model.links:
        return TOOL_LINKS[model.name]
    for key, name in TOOL_LINKS.items():
        if name in model.links:
            return name
    return max(model.leaf_links, key=lambda l: sum(1 for j in model.path_joints(l) if j.moving))


def configurations(model, n: int) -> np.ndarray:
    """``n`` random configurations (N, dof) within the limits (continuous joints in +-2 pi)."""
    return model.sample_configurations(n, np.random.default_rng(SEED))


#: Clock of the in-process measurements: CPU time of this thread, so that time the core spends
#: on other processes of the shared machine is not counted (ours and Pinocchio's code are both
#: single-threaded here: BLAS is limited to one thread by run_all). The service uses wall time.
#: ``BENCH_CLOCK=wall`` selects wall time (time.perf_counter) instead.
if os.environ.get("BENCH_CLOCK", "cpu") == "wall":
    CLOCK = time.perf_counter
    CLOCK_NAME = "wall time (time.perf_counter)"
else:
    CLOCK = time.thread_time
    CLOCK_NAME = "CPU time of the benchmarking thread (time.thread_time)"


def best_of(fn: Callable[[], object], rounds: int = 3,
            clock: Callable[[], float] = time.perf_counter) -> float:
    """The best seconds of ``rounds`` calls of ``fn`` by ``clock`` (wall clock by default: the best of a
    few long calls on a shared machine)."""
    best = float("inf")
    for _ in range(rounds):
        t0 = clock()
        fn()
        best = min(best, clock() - t0)
    return best


def measure(fns: dict[str, Callable[[], object]], rounds: int = 5, min_time: float = 0.05,
            max_inner: int = 100_000, clock: Callable[[], float] | None = None) -> dict[str, float]:
    """Seconds per call of each function: the best of ``rounds`` interleaved rounds.

    Each round times ``inner`` calls (chosen so a round lasts about ``min_time``). Taking the
    best round filters out other processes on a shared machine; interleaving puts ours and
    Pinocchio's under the same conditions. ``clock`` defaults to :data:`CLOCK`.
    """
    clock = clock or CLOCK
    inner = {}
    for name, fn in fns.items():
        t0 = time.perf_counter()
        fn()
        dt = max(time.perf_counter() - t0, 1e-7)
        inner[name] = int(min(max_inner, max(1, min_time / dt)))
    best = {name: float("inf") for name in fns}
    for _ in range(rounds):
        for name, fn in fns.items():
            k = inner[name]
            t0 = clock()
            for _ in range(k):
                fn()
            best[name] = min(best[name], (clock() - t0) / k)
    return best


def percentile_times(fn: Callable[[], object], count: int) -> np.ndarray:
    """Seconds of ``count`` individual calls of ``fn``."""
    out = np.empty(count)
    for i in range(count):
        t0 = time.perf_counter()
        fn()
        out[i] = time.perf_counter() - t0
    return out


def us(seconds: float) -> str:
    return f"{seconds * 1e6:.3f}" if seconds < 1e-4 else f"{seconds * 1e6:.1f}"


def ms(seconds: float) -> str:
    return f"{seconds * 1e3:.2f}"


def table(headers: list[str], rows: list[list[object]]) -> str:
    """A markdown table."""
    lines = ["| " + " | ".join(headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


@dataclass
class Report:
    """Sections of markdown, printed as they come and collected for RESULTS.md."""

    sections: list[str] = field(default_factory=list)

    def add(self, title: str, body: str, note: str = "") -> None:
        text = f"### {title}\n\n{body}\n" + (f"\n{note}\n" if note else "")
        print(text, flush=True)
        self.sections.append(text)


def run_parts(prog: str, doc: str, parts: dict[str, Callable[[Report, bool], object]], default: str,
              argv: list[str] | None = None) -> Report:
    """A suite's tables run on their own (``python -m bench.<suite>``): ``--quick``, and ``--only``
    a comma-separated list of names of ``parts`` (default ``default``), each called as
    ``part(report, quick)`` in the order given; returns the report."""
    import argparse

    p = argparse.ArgumentParser(prog=prog, description=doc.splitlines()[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--only", default=default)
    a = p.parse_args(argv)
    report = Report()
    for part in a.only.split(","):
        parts[part](report, a.quick)
    return report


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def blas_info() -> list[dict]:
    from threadpoolctl import threadpool_info

    return [i for i in threadpool_info() if i.get("user_api") == "blas"]


def machine_info() -> str:
    import pinocchio

    try:
        from importlib.metadata import version

        mr_version = version("modern_robotics")
    except Exception:  # noqa: BLE001 - only for the report
        mr_version = "not installed"
    blas = blas_info()
    blas_text = "; ".join(
        f"{b.get('internal_api')} {b.get('version')} (kernel/core type {b.get('architecture')}, "
        f"{b.get('num_threads')} threads, {os.path.basename(b.get('filepath', ''))})" for b in blas
    ) or "none found"
    env = {k: os.environ.get(k) for k in ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE", "OPENBLAS_NUM_THREADS",
                                          "OMP_NUM_THREADS", "MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_")}
    rows = [
        ["date (UTC)", datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M")],
        ["CPU", cpu_model()],
        ["cores (usable)", f"{os.cpu_count()} ({len(os.sched_getaffinity(0))})"],
        ["load average at start", " ".join(f"{x:.2f}" for x in os.getloadavg())],
        ["Python", platform.python_version()],
        ["numpy", np.__version__],
        ["BLAS (threadpoolctl)", blas_text],
        ["pinocchio", pinocchio.__version__],
        ["modern_robotics", mr_version],
        ["clock (in-process tables)", CLOCK_NAME],
        ["environment", ", ".join(f"{k}={v}" for k, v in env.items() if v is not None) or "(none of the OPENBLAS/MALLOC variables set)"],
    ]
    return table(["", ""], rows)
