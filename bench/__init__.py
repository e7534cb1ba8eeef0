"""Benchmarks of the kinematics library and service, as ratios against Pinocchio in the same run.

Run everything with ``python -m bench.run_all`` (``make bench``); see ``bench/RESULTS.md``.
Times are measured here, never asserted in tests.
"""
