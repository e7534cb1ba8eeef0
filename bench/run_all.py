"""Run every benchmark and print markdown tables (``python -m bench.run_all``, ``make bench``).

Options: ``--quick`` (smaller batches, for a smoke run), ``--only kernels,scaling,service,ik,ik-all,load,calibration,collision``
(default: all but ``ik``, which needs the baselines of the ``bench`` extra and takes minutes, and
``logs``, ``load`` and ``single``; ``load`` writes ``RESULTS_LOAD.md``, ``single`` (one configuration
at a time, with the spread over repeated runs) ``RESULTS_SINGLE.md``),
``--output bench/RESULTS.md`` (also write the tables there, with the date and the command; the
``ik`` suite's tables go to their own file beside it, ``RESULTS_IK.md``, so that running one
alone never overwrites the other's; ``ik-all``, every IK solution against EAIK and IK-Geo (the
``ik-all-baselines`` extra), writes ``RESULTS_IK_ALL.md``),
``--blas-threads N`` (default 1: Pinocchio's loop is single-threaded, so ours is too).

To benchmark the BLAS kernel that matches this CPU, unset the OpenBLAS overrides in the
benchmark command only: ``env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE python -m bench.run_all``;
the machine table reports which kernel ran.
"""

from __future__ import annotations

import argparse
import os
import shlex
import sys
import time

from .common import Report, machine_info

SUITES = ("kernels", "scaling", "service", "ik", "ik-all", "logs", "floating", "load", "calibration", "single", "collision",
          "ik-general", "trajectory")
#: the suites run when --only is not given
DEFAULT_SUITES = ("kernels", "scaling", "service")
#: suites whose tables are written to their own file, beside --output (not into it)
SEPARATE_OUTPUT = {"ik": "RESULTS_IK.md", "logs": "RESULTS_LOGS.md", "floating": "RESULTS_FLOATING.md",
                   "load": "RESULTS_LOAD.md", "calibration": "RESULTS_CALIBRATION.md",
                   "single": "RESULTS_SINGLE.md",
                   "collision": "RESULTS_COLLISION.md", "ik-all": "RESULTS_IK_ALL.md",
                   "ik-general": "RESULTS_IK_GENERAL.md", "trajectory": "RESULTS_TRAJECTORY.md"}
#: In the --output file, everything from this line on is kept when the tables are rewritten.
NOTES_MARKER = "<!-- notes: kept by run_all -->"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.run_all", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller batches and shorter loops")
    parser.add_argument("--only", default=",".join(DEFAULT_SUITES),
                        help=f"comma-separated subset of {', '.join(SUITES)} (default {','.join(DEFAULT_SUITES)})")
    parser.add_argument("--output", help="write the report (markdown) to this file")
    parser.add_argument("--blas-threads", type=int, default=1, help="BLAS threads for our kernels (default 1)")
    parser.add_argument("--command", help="the command line to record in the report (default: this one)")
    args = parser.parse_args(argv)
    suites = [s.strip() for s in args.only.split(",") if s.strip()]
    unknown = [s for s in suites if s not in SUITES]
    if unknown:
        parser.error(f"unknown suite(s): {', '.join(unknown)} (choose from {', '.join(SUITES)})")

    from threadpoolctl import threadpool_limits

    command = args.command or "python -m bench.run_all " + " ".join(shlex.quote(a) for a in (argv or sys.argv[1:]))
    report = Report()
    by_suite: dict[str, list[str]] = {}
    t0 = time.perf_counter()
    with threadpool_limits(limits=args.blas_threads, user_api="blas"):
        header = machine_info()
        print(header, flush=True)
        for name in suites:
            module = __import__(f"bench.{name.replace('-', '_')}", fromlist=["run"])
            first = len(report.sections)
            module.run(report, quick=args.quick)
            by_suite[name] = report.sections[first:]
    elapsed = time.perf_counter() - t0
    print(f"\nbenchmarks took {elapsed:.0f} s", flush=True)
    if args.output:
        outputs: dict[str, list[str]] = {}  # file -> sections, in the order of the suites
        for name in suites:
            path = (os.path.join(os.path.dirname(args.output), SEPARATE_OUTPUT[name])
                    if name in SEPARATE_OUTPUT else args.output)
            outputs.setdefault(path, []).extend(by_suite[name])
        for path, sections in outputs.items():
            own = [n for n in suites if path != args.output and SEPARATE_OUTPUT.get(n) == os.path.basename(path)]
            title = "Benchmark results" + (f" ({', '.join(own)})" if own else "")
            write_report(path, title, sections, command, header, elapsed, args.blas_threads)
            print(f"wrote {path}", flush=True)
    return 0


def write_report(path: str, title: str, sections: list[str], command: str, header: str, elapsed: float,
                 blas_threads: int) -> None:
    """Rewrite ``path`` with these tables, keeping what follows :data:`NOTES_MARKER` in it."""
    notes = ""
    try:  # keep the hand-written reading of the results below the marker
        with open(path) as f:
            old = f.read()
        if NOTES_MARKER in old:
            notes = old[old.index(NOTES_MARKER):]
    except OSError:
        pass
    with open(path, "w") as f:
        f.write(f"# {title}\n\n")
        f.write(f"Command: `{command}` (BLAS limited to {blas_threads} thread(s) by threadpoolctl; "
                f"the run took {elapsed:.0f} s).\n\n")
        f.write("## Machine\n\n" + header + "\n\n## Results\n\n")
        f.write("\n".join(sections))
        if notes:
            f.write("\n" + notes)


if __name__ == "__main__":
    sys.exit(main())
