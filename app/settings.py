"""Service settings: one class, read from ``KIN_*`` environment variables, overridable in tests.

Every limit the service enforces is here (no literal buried in a handler):

=========================  ==========================  =======================================
variable                   default                     meaning
=========================  ==========================  =======================================
``KIN_DATA_DIR``           ``./data`` (working dir)    uploaded and DH-built models (shared
                                                       by every worker / replica)
``KIN_MAX_MODEL_BYTES``    8 MiB                       a URDF or DH table body
``KIN_MAX_REQUEST_BYTES``  64 MiB                      any request body
``KIN_MAX_BATCH``          1,000,000                   configurations in one request
``KIN_MAX_LINKS``          10,000                      links (and joints) in one model
``KIN_MAX_VERIFY``         10,000                      configurations one ``verify`` may check
``KIN_MAX_RESULT_VALUES``  32,000,000                  numbers in one FK / Jacobian answer
``KIN_MAX_WORKSPACE_SAMPLES`` 1,000,000                configurations one workspace request
                                                       may sample
``KIN_MAX_IK_SOLUTIONS``   1,000,000                   IK solutions one request may list: targets
                                                       (or a path's interpolated targets) x the most
                                                       solutions the chain can have, checked before
                                                       the work
``KIN_MAX_MEASUREMENTS``   100,000                     measurements of one calibration (JSON or file)
``KIN_COLLISION_SAMPLES``  10,000                      random configurations behind a model's
                                                       allowed-collision matrix (computed once,
                                                       kept in the data directory)
``KIN_SYMBOLIC_TIMEOUT``   30                          seconds one closed-form request may take
``KIN_MAX_ARCHIVE_BYTES``  64 MiB                      a description archive body (zip, gzip, tar)
``KIN_MAX_ARCHIVE_EXTRACTED_BYTES`` 64 MiB             description files extracted from one
                                                       archive (meshes are never extracted)
``KIN_MAX_ARCHIVE_MEMBERS`` 20,000                     members of one archive
``KIN_XACRO_CPU_SECONDS``  10                          CPU time of one sandboxed xacro expansion
``KIN_XACRO_MEMORY_BYTES`` 1 GiB                       address space of that process
``KIN_XACRO_MAX_MACRO_CALLS`` 20,000                   macro calls in one expansion
``KIN_REQUEST_TIMEOUT``    60                          seconds the heavy work of one request may take
                                                       (FK / Jacobian / velocity batches, IK,
                                                       workspace; queue time included): then it
                                                       stops, 503 ``time-budget-exceeded``
``KIN_MAX_HEAVY_JOBS``     2                           heavy requests computed at once per worker
                                                       process (the others queue)
``KIN_HEAVY_NICE``         5                           how much lower the scheduling priority of
                                                       the heavy threads is (0: the same)
``KIN_DECODE_PROCESS_BYTES`` 256 KiB                   JSON bodies over this are decoded in a
                                                       per-worker process (0: never)
``KIN_SWITCH_INTERVAL``    0.005                       the workers' GIL switch interval, seconds
``KIN_BLAS_THREADS``       1                           threads of BLAS / LAPACK (OpenBLAS) in each
                                                       worker (0: the library's own default)
``KIN_SHUTDOWN_TIMEOUT``   30                          seconds in-flight requests get to finish
                                                       after SIGTERM (``kinematics serve``,
                                                       the container); then they are cancelled
``KIN_WARM_UP``            ``background``              the compiled kernels' warm-up (app/warm.py):
                                                       in a thread while the worker answers
                                                       (/health: ``warm_up``), or
                                                       ``before_serving``
``KIN_CORS_ORIGINS``       (none)                      comma-separated or JSON list
``KIN_LOG_LEVEL``          ``info``                    logging level of the ``app`` logger
``KIN_LOG_FORMAT``         ``text``                    ``json``: access and error logs as one JSON
                                                       object per line (time, level, logger,
                                                       message, request_id; access: method,
                                                       path, route, status, duration_ms,
                                                       problem; errors: exception, traceback)
``KIN_API_KEY``            (unset)                     when set, writes need it
``KIN_API_KEY_FOR_READS``  ``false``                   when true (and a key is set), reads
                                                       need it too
=========================  ==========================  =======================================

The key goes in ``X-API-Key: <key>`` or ``Authorization: Bearer <key>``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import Field, SecretStr, field_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict

MIB = 1024 * 1024


class Settings(BaseSettings):
    """Configuration of one service process (see the module docstring for the variables)."""

    model_config = SettingsConfigDict(env_prefix="KIN_", extra="ignore")

    data_dir: Path = Field(default=Path("data"), description="directory of uploaded and DH-built models")
    max_model_bytes: int = Field(default=8 * MIB, gt=0, description="largest URDF or DH table body, bytes")
    max_request_bytes: int = Field(default=64 * MIB, gt=0, description="largest request body, bytes")
    max_batch: int = Field(default=1_000_000, gt=0, description="most configurations in one request")
    max_links: int = Field(default=10_000, gt=0, description="most links (and joints) in one model")
    max_verify: int = Field(default=10_000, gt=0, description="most configurations one verify=true may check")
    max_ik_work: int = Field(default=100_000_000, gt=0,
                             description="most IK steps one request may take: targets x (restarts + 1) x max_iterations")
    max_result_values: int = Field(default=32_000_000, gt=0,
                                   description="most numbers in one FK / Jacobian answer (N x links x 16, N x 6 x dof)")
    max_ik_solutions: int = Field(default=1_000_000, gt=0,
                                  description="most IK solutions one request may list (every solution of every "
                                              "target, or of every target of a path), counted before the work")
    max_measurements: int = Field(default=100_000, gt=0, description="most measurements in one calibration")
    collision_samples: int = Field(default=10_000, gt=0, le=1_000_000,
                                   description="random configurations behind a model's allowed-collision matrix")
    max_workspace_samples: int = Field(default=1_000_000, gt=0,
                                       description="most configurations one workspace request may sample")
    trajectory_max_rate: float = Field(default=100_000.0, gt=0, le=100_000,
                                       description="largest sampling rate of a trajectory, Hz (over it: 413)")
    trajectory_max_samples: int = Field(default=1_000_000, gt=0, description="most samples of one trajectory answer")
    symbolic_timeout: float = Field(default=30.0, gt=0, le=3600,
                                    description="most seconds one closed-form (symbolic) request may take; its "
                                                "derivation runs in a worker process that is stopped then")
    max_archive_bytes: int = Field(default=64 * MIB, gt=0,
                                   description="largest description archive body (zip, gzip, tar), bytes")
    max_archive_extracted_bytes: int = Field(default=64 * MIB, gt=0,
                                             description="most bytes of description files extracted from one archive")
    max_archive_members: int = Field(default=20_000, gt=0, description="most members in one description archive")
    xacro_cpu_seconds: float = Field(default=10.0, gt=0, le=600,
                                     description="CPU time of one xacro expansion (its sandboxed process's RLIMIT_CPU)")
    xacro_memory_bytes: int = Field(default=1024 * MIB, ge=128 * MIB,
                                    description="address space of one xacro expansion process (RLIMIT_AS)")
    xacro_max_macro_calls: int = Field(default=20_000, gt=0, description="most macro calls in one xacro expansion")
    request_timeout: float = Field(default=60.0, gt=0, le=86_400,
                                   description="most seconds the heavy work of one request may take (queue included); "
                                               "then it stops with 503 time-budget-exceeded")
    max_heavy_jobs: int = Field(default=2, ge=1, le=256, description="heavy requests computed at once per worker process")
    heavy_nice: int = Field(default=5, ge=0, le=19, description="nice increment of the threads doing heavy work")
    switch_interval: float = Field(default=0.005, gt=0, le=1,
                                   description="seconds a thread may hold the GIL while another waits for it "
                                               "(sys.setswitchinterval of each worker)")
    blas_threads: int = Field(default=1, ge=0, le=256,
                              description="threads of BLAS / LAPACK in each worker (0: the library's default); "
                                          "more spin on the cores the event loop needs")
    decode_process_bytes: int = Field(default=256 * 1024, ge=0,
                                      description="JSON bodies over this many bytes are decoded in a separate "
                                                  "process of the worker (0: never)")
    shutdown_timeout: float = Field(default=30.0, ge=0, le=3600,
                                    description="seconds in-flight requests get to finish after SIGTERM")
    warm_up: Literal["background", "before_serving"] = Field(
        default="background", description="load the compiled kernels in a thread while answering (/health tells "
                                          "when they are loaded), or before the worker answers anything")
    cors_origins: Annotated[list[str], NoDecode] = Field(default_factory=list)
    log_level: str = "info"
    log_format: Literal["text", "json"] = Field(
        default="text", description="json: access and error logs as one JSON object per line (app/logs.py)")
    api_key: SecretStr | None = None
    api_key_for_reads: bool = False

    @field_validator("cors_origins", mode="before")
    @classmethod
    def _split_origins(cls, v):
        if isinstance(v, str):
            v = v.strip()
            if v.startswith("["):
                import json

                return json.loads(v)
            return [o.strip() for o in v.split(",") if o.strip()]
        return v

    @field_validator("api_key", mode="before")
    @classmethod
    def _empty_key_is_none(cls, v):
        return None if v is None or (isinstance(v, str) and v == "") else v

    def resolved_data_dir(self) -> Path:
        """The data directory as an absolute path (relative paths are under the working directory)."""
        return Path(self.data_dir).expanduser().resolve()
