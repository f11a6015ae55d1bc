# The two commands: `make run` (set up, then a real calibration campaign) and `make test` (the fast
# tier, on every change); `make test-all` runs the full tier, `make docs` builds the documentation
# site into site/ (docs/how-to/run-the-tests.md).
# Set-up installs only what is missing: Debian's liggghts and yade (the engines), slurm-wlm (the
# cluster test) and chromium with its driver (the report's browser test), a .venv with the CPU torch
# wheel (pinned so that pip does not fetch CUDA builds), calibrax and its builtin backends.

SHELL := /bin/bash
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.calibrax-installed
SUDO := $(shell [ "$$(id -u)" -eq 0 ] || echo sudo)
TORCH := torch==2.13.0
# Numba's cache is checked against each kernel's own file only, not the files it inlines from (a
# change to contact.py leaves engine.py's cached kernels stale), so the cache is keyed by a hash of
# all of numba_dem's sources (cache_key.py, standard library only; tests/conftest.py uses the same)
NUMBA_SRC_HASH := $(shell python3 plugins/numba_dem/src/calibrax_numba_dem/cache_key.py)
export NUMBA_CACHE_DIR ?= $(CURDIR)/.numba_cache/$(NUMBA_SRC_HASH)
# pytest-xdist workers of the test tiers (the machines CI uses have 2 cores); each module runs on one
# worker (its module-scoped fixtures run once), in the order collected (the integration tests, the
# longest, first); the simulation bank runs beside them and serves both (tests/bank.py)
TEST_WORKERS ?= 2
PYTEST := $(PY) -m pytest -q -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder --durations=25

.PHONY: run test test-all docs setup engines clean-runs

run: setup
	$(VENV)/bin/calibrax run examples/quickstart.yaml
	$(VENV)/bin/calibrax status runs/quickstart.h5

# the fast tier: every test not marked slow, each engine still running a whole shear test
test: setup
	$(PYTEST) --tier fast

# the full tier: everything (the engines' campaigns and physics, the end-to-end studies)
test-all: setup
	$(PYTEST) --tier all

# the documentation site (MkDocs, docs/ and mkdocs.yml) into site/; strict: a broken link, a missing
# page or an API name that no longer exists is an error (the fast tier builds it the same way);
# NO_MKDOCS_2_WARNING silences the Material theme's notice about MkDocs 2.0, which is not ours
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict --site-dir site

setup: engines $(STAMP) $(NUMBA_CACHE_DIR)/.compiled

# numba_dem's kernels compiled once here, not by each of the first simulations side by side
$(NUMBA_CACHE_DIR)/.compiled: $(STAMP)
	$(PY) -m calibrax_numba_dem.warmup
	mkdir -p $(NUMBA_CACHE_DIR) && touch $@

engines:
	@if ! command -v liggghts >/dev/null || ! command -v yade >/dev/null || ! command -v slurmctld >/dev/null \
			|| ! command -v chromium >/dev/null || ! command -v chromedriver >/dev/null; then \
		echo "installing the DEM engines liggghts and yade, slurm-wlm for the cluster test and chromium for the report's browser test (Debian packages)"; \
		$(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq liggghts yade slurm-wlm chromium chromium-driver; \
	fi

$(STAMP): pyproject.toml plugins/numba_dem/pyproject.toml plugins/liggghts/pyproject.toml plugins/yade/pyproject.toml
	test -x $(PY) || python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q $(TORCH)
	$(PY) -m pip install -q $(TORCH) -e '.[dev,dask,docs]' -e plugins/numba_dem -e plugins/liggghts -e plugins/yade
	touch $(STAMP)

clean-runs:
	rm -rf runs
