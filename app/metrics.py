"""Prometheus metrics of the service (``GET /metrics``), with PyPI ``prometheus-client``.

The metrics live in the client's default registry, created once per process. With several
workers, set ``PROMETHEUS_MULTIPROC_DIR`` to an empty writable directory (the same for every
worker, emptied before the server starts): each worker then writes its values there and
``/metrics`` aggregates them (the client's multiprocess mode). The library knows nothing of
this module; the routes report what they computed.
"""

from __future__ import annotations

import os

from prometheus_client import CONTENT_TYPE_LATEST, CollectorRegistry, Counter, Gauge, Histogram, generate_latest
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
MODELS_COMPILED = Counter("kin_models_compiled", "models compiled to their product-of-exponentials form (the "
                          "kernels' input; once per model and process, the start-up warm-up's included)")
MODELS_CACHED = Gauge("kin_models_cached", "compiled models held in memory (summed over live workers)",
                      multiprocess_mode="livesum")
HEAVY_RUNNING = Gauge("kin_heavy_jobs_running", "heavy jobs computing now (IK, large batches, the decoding of large "
                      "JSON bodies: app.heavy), summed over live workers", multiprocess_mode="livesum")

_compiled_seen = 0


def record_models() -> None:
    """Bring the model counts up to date with the library's (:func:`kinematics.usecases.compiled_models`;
    called after each request and before each exposition: the app observes, the library compiles)."""
    global _compiled_seen
    from kinematics import api

    compiled, cached = api.compiled_models()
    if compiled > _compiled_seen:
        MODELS_COMPILED.inc(compiled - _compiled_seen)
        _compiled_seen = compiled
    MODELS_CACHED.set(cached)


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
    record_models()
    if os.environ.get("PROMETHEUS_MULTIPROC_DIR"):
        from prometheus_client import multiprocess

        registry = CollectorRegistry()
        multiprocess.MultiProcessCollector(registry)
    else:
        registry = DEFAULT_REGISTRY
    return generate_latest(registry), CONTENT_TYPE_LATEST
