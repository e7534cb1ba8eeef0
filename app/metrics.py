"""Prometheus metrics of the service (``GET /metrics``), with PyPI ``prometheus-client``.

The metrics live in the client's default registry, created once per process. With several
workers, set ``PROMETHEUS_MULTIPROC_DIR`` to an empty writable directory (the same for every
worker, emptied before the server starts): each worker then writes its values there and
``/metrics`` aggregates them (the client's multiprocess mode). The library knows nothing of
this module; the routes report what they computed.
"""

from __future__ import annotations

import os

from prometheus_client import CONTENT_TYPE_LATEST, CollectorRegistry, Counter, Histogram, generate_latest
from prometheus_client import REGISTRY as DEFAULT_REGISTRY

LATENCY_BUCKETS = (0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0, 30.0, 60.0)
ITERATION_BUCKETS = (1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 10_000)

REQUESTS = Counter("kin_http_requests", "HTTP requests answered, by method, route template and status",
                   ("method", "route", "status"))
LATENCY = Histogram("kin_http_request_duration_seconds", "HTTP request latency (until the answer is sent), "
                    "by method, route template and status", ("method", "route", "status"), buckets=LATENCY_BUCKETS)
IK_TARGETS = Counter("kin_ik_targets", "IK targets solved, by outcome (success: within tolerance and limits)",
                     ("outcome",))
IK_ITERATIONS = Histogram("kin_ik_iterations", "iterations spent on each IK target", buckets=ITERATION_BUCKETS)
CONFIGURATIONS = Counter("kin_configurations", "joint configurations processed, by operation", ("operation",))


def record_ik(success, iterations) -> None:
    """Count one IK answer: ``success`` and ``iterations`` are per-target arrays."""
    ok = int(sum(bool(s) for s in success))
    IK_TARGETS.labels("success").inc(ok)
    IK_TARGETS.labels("failure").inc(len(success) - ok)
    for it in iterations:
        IK_ITERATIONS.observe(float(it))
    CONFIGURATIONS.labels("ik").inc(len(success))


def record_configurations(operation: str, count: int) -> None:
    CONFIGURATIONS.labels(operation).inc(count)


def exposition() -> tuple[bytes, str]:
    """The text exposition of every metric (aggregated over workers in multiprocess mode)."""
    if os.environ.get("PROMETHEUS_MULTIPROC_DIR"):
        from prometheus_client import multiprocess

        registry = CollectorRegistry()
        multiprocess.MultiProcessCollector(registry)
    else:
        registry = DEFAULT_REGISTRY
    return generate_latest(registry), CONTENT_TYPE_LATEST
