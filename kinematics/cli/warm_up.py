"""``kinematics warm-up``: load every operation's compiled kernels, compiling (and caching) what is missing.

numba compiles the kernels on their first use on a machine and keeps them in its disk cache; this
command does it once, saying what it does and how long each step takes, so that a server or a
script started later reads the cache (seconds) instead of compiling (minutes). ``make install``
and the Docker build run it.
"""

from __future__ import annotations

import time

from . import add_command


def register(sub) -> None:
    add_command(
        sub, "warm-up", run, model=False,
        help="compile (or load from the cache) every operation's numba kernels",
        description="Load every operation's compiled kernels: on the first run on a machine numba compiles "
        "them and writes its disk cache (minutes on a busy 2-core machine), later runs read the cache (seconds). "
        "`make install` and the Docker build run it so that the service's first start does not compile.",
    )


def run(args) -> int:
    from ..usecases.warm import warm_up

    print("warm-up: loading the compiled kernels (the first run on a machine compiles them and fills numba's "
          "cache: minutes; later runs read it: seconds)", flush=True)

    def progress(step: str, seconds: float) -> None:
        print(f"  {seconds:7.1f} s  {step}", flush=True)

    start = time.perf_counter()
    warm_up(progress)
    print(f"warm-up: done in {time.perf_counter() - start:.1f} s", flush=True)
    return 0
