ARG BASE_IMAGE=python:3.11-slim
# The kinematics service as a container.
#
#   docker build -t kinematics .
#   docker run -p 8000:8000 -v kin-data:/data kinematics
#
# BASE_IMAGE may be any Debian bookworm image: with Python (python:3.11-slim, the default)
# or without it (CI passes a plain debootstrapped bookworm), in which case Python 3.11 is
# installed from Debian's packages. Two stages: `build` makes a virtualenv with the
# project and its dependencies (wheels only; no compiler is needed or shipped), `runtime`
# copies that virtualenv onto a clean base and runs as a non-root user.
#
# Configuration is by environment variables only (app/settings.py lists the KIN_*
# variables); PORT and WEB_CONCURRENCY set uvicorn's port and worker count. Uploaded and
# DH-built models live in the volume /data (KIN_DATA_DIR), shared by every worker.

FROM ${BASE_IMAGE} AS base
ENV DEBIAN_FRONTEND=noninteractive \
    PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1
# From Debian, only what the base lacks: Python (python:3.11-slim already has it) and the
# runtime libraries the Pinocchio/Boost wheels link to but do not bundle (OpenMP, quadmath).
RUN need=""; \
    command -v python3 >/dev/null 2>&1 || need="python3"; \
    ldconfig -p | grep -q 'libgomp\.so\.1 ' || need="$need libgomp1"; \
    ldconfig -p | grep -q 'libquadmath\.so\.0 ' || need="$need libquadmath0"; \
    if [ -n "$need" ]; then \
        apt-get update -q \
        && apt-get install -y -q --no-install-recommends $need \
        && rm -rf /var/lib/apt/lists/* /var/cache/apt/archives/*.deb; \
    fi \
    && python3 -c 'import sys; assert sys.version_info >= (3, 11), sys.version'

# ---------------------------------------------------------------- build stage
FROM base AS build
# venv + ensurepip come with python3-venv on Debian (the official python image has them built in)
RUN python3 -m venv /opt/venv >/dev/null 2>&1 || { \
        apt-get update -q \
        && apt-get install -y -q --no-install-recommends python3-venv \
        && rm -rf /var/lib/apt/lists/* \
        && rm -rf /opt/venv && python3 -m venv /opt/venv; }
ENV PATH=/opt/venv/bin:$PATH \
    PIP_DISABLE_PIP_VERSION_CHECK=1
WORKDIR /src
# Dependencies first, from pyproject.toml alone (a stub package), so that editing the
# source does not re-download ~700 MB of wheels. The `all` extra: the service, Pinocchio,
# example-robot-data, MuJoCo, xacro, sympy, matplotlib, and the logs and dask extras (the image
# reads ROS bags and Parquet and serves as the worker image of a Dask cluster).
COPY pyproject.toml setup.py README.md ./
RUN --mount=type=cache,target=/root/.cache/pip \
    mkdir -p kinematics app models \
    && touch kinematics/__init__.py app/__init__.py \
    && pip install -q --upgrade pip setuptools wheel \
    && pip install -q '.[all]' \
    && pip uninstall -y -q kinematics-service \
    && rm -rf kinematics app models build *.egg-info
# What the service never reads, removed from the venv: C++ headers, CMake files and static
# libraries of the Pinocchio wheels, numba's and llvmlite's own test suites. The meshes of the
# example-robot-data URDFs stay: self-collision and the viewer read the catalogue's meshes from
# the installed package (never a path an upload names).
RUN cd /opt/venv/lib/python3*/site-packages/cmeel.prefix \
    && rm -rf include share/cmake share/doc lib/cmake lib/pkgconfig lib64/cmake lib64/pkgconfig \
    && find . -name '*.a' -delete \
    && rm -rf ../numba/tests ../llvmlite/tests
# yourdfpy pulls in trimesh[easy]: mesh processing libraries that trimesh imports only to
# process meshes, which this service never does (it reads STL, OBJ and Collada: numpy and
# pycollada). scipy stays (calibration), pillow stays (matplotlib's plots), pycollada stays.
RUN pip uninstall -y -q embreex networkx shapely manifold3d rtree vhacdx mapbox-earcut svg.path xxhash
COPY kinematics ./kinematics
COPY app ./app
COPY models ./models
RUN --mount=type=cache,target=/root/.cache/pip \
    pip install -q --no-deps --no-build-isolation . \
    && python -c 'import kinematics, app.main, scipy, coal, trimesh, collada; print("kinematics", kinematics.__version__)' \
    && NUMBA_CACHE_DIR=/tmp/numba-build kinematics check --samples 1 | tail -1 \
    && pip uninstall -y -q pip setuptools wheel \
    && rm -rf /src

# ---------------------------------------------------------------- runtime stage
FROM base AS runtime
RUN (getent group kin || groupadd --gid 10001 kin) \
    && useradd --uid 10001 --gid kin --home-dir /home/kin --create-home --shell /usr/sbin/nologin kin \
    && mkdir -p /data \
    && chown kin:kin /data
COPY --from=build /opt/venv /opt/venv
# The DH presets of the textbook robots (models/) ship inside the package (kinematics/models),
# and the example-robot-data catalogue is inside the venv.
ENV PATH=/opt/venv/bin:$PATH \
    KIN_DATA_DIR=/data \
    PORT=8000 \
    WEB_CONCURRENCY=1 \
    KIN_SHUTDOWN_TIMEOUT=8
VOLUME ["/data"]
WORKDIR /home/kin
USER kin
# Compile the numba kernels now, into the user's cache (~/.cache/numba), so that the server
# starts in about a second; on a machine with another CPU, numba compiles them again at start.
RUN kinematics warm-up
EXPOSE 8000
HEALTHCHECK --interval=30s --timeout=5s --start-period=20s --retries=3 \
    CMD ["python", "-c", "import os, sys, urllib.request; r = urllib.request.urlopen('http://127.0.0.1:%s/health' % os.environ.get('PORT', '8000'), timeout=4); sys.exit(r.status != 200)"]
# Exec form: the server is PID 1 and gets `docker stop`'s SIGTERM itself. `python -m app` reads PORT and
# WEB_CONCURRENCY; on SIGTERM it refuses new connections and lets requests in flight finish for up to
# KIN_SHUTDOWN_TIMEOUT seconds (8 in this image, under `docker stop`'s default 10 s: raise both together,
# e.g. `docker run --stop-timeout 65 -e KIN_SHUTDOWN_TIMEOUT=60`, or Kubernetes' terminationGracePeriodSeconds).
STOPSIGNAL SIGTERM
CMD ["python", "-m", "app", "--host", "0.0.0.0"]
