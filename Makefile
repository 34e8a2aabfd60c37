# Every target creates .venv from the project's files when it is missing or out of date:
# requirements.lock pins every package (hashes included), so a fresh machine installs exactly
# what the tests passed with. uv installs it (pinned and hashed in tools/uv-requirements.txt):
# 3-4 s where pip took 55 s for the same 137 packages. `make lock` refreshes the lock from the
# ranges in pyproject.toml; `make test-latest` runs the tests against the newest releases those
# ranges allow.
PYTHON     ?= python3
VENV       := .venv
BIN        := $(VENV)/bin
STAMP      := $(VENV)/.installed
LOCK       := requirements.lock
UV_LOCK    := tools/uv-requirements.txt
TOOLS      := .venv-tools
LATEST     := .venv-latest
PEERS      := .venv-peers
PEERS_LOCK := benchmarks/peers-requirements.txt
PYOMA      := .venv-pyoma
PYOMA_LOCK := benchmarks/pyoma-requirements.txt
# pytest-xdist processes of the fast tier (one a core of the 2-core machine); --dist loadfile:
# each test file is one unit, so that module-scoped fixtures are built once (tests/conftest.py
# also keeps together the files that share the tiny `reproduce` run)
WORKERS    ?= 2
XDIST      := -n $(WORKERS) --dist loadfile

.PHONY: reproduce test test-long test-other-isa test-slow test-all test-latest lint bench beyond fidelity \
	peers pyoma lock clean docs

# setup.py and window.cc: the grey box's training kernel, compiled by the editable install
# (uv reads UV_DEFAULT_INDEX / UV_INDEX_URL, not pip's configuration, for a private index).
# --compile-bytecode: the packages' .pyc written once, here, as pip does; uv would leave them to
# the first import, and where PYTHONDONTWRITEBYTECODE is set every process would compile JAX,
# SciPy and the rest again (the package's import 7.5 s instead of 2.8 s, in each test worker,
# each command the tests run, each Dask or pool worker). The numba kernels of a default run
# compile into numba's cache while the C++ kernel builds (tools/warm_kernels.py; one core each).
# The venv is made without pip (ensurepip's copy took 2.8 s): the system's pip installs uv into
# it (pip >= 22.3's --python); a Python without such a pip bootstraps the venv's own instead
$(STAMP): $(LOCK) $(UV_LOCK) pyproject.toml setup.py src/sloshrom/rom/grey/window.cc
	test -x $(BIN)/python || $(PYTHON) -m venv --without-pip $(VENV)
	$(PYTHON) -m pip --python $(BIN)/python install --quiet --require-hashes --no-deps \
		-r $(UV_LOCK) 2>/dev/null || { $(BIN)/python -m ensurepip --default-pip >/dev/null \
		&& $(BIN)/python -m pip install --quiet --require-hashes --no-deps -r $(UV_LOCK); }
	$(BIN)/uv pip install --quiet --python $(BIN)/python --require-hashes --no-deps \
		--compile-bytecode -r $(LOCK)
	PYTHONPATH=src $(BIN)/python tools/warm_kernels.py & warm=$$!; \
	$(BIN)/uv pip install --quiet --python $(BIN)/python --no-deps --no-build-isolation -e . \
		&& wait $$warm
	$(BIN)/uv pip check --quiet --python $(BIN)/python
	touch $(STAMP)

reproduce: $(STAMP)
	$(BIN)/sloshrom reproduce --out results

# ruff, the fast tier (in WORKERS processes; neither the long nor the slow tests), then mypy
# (gradual for the package, strict for the modules pyproject.toml lists; cache in .mypy_cache/,
# git-ignored; in WORKERS processes: 15 s instead of 27 s without its cache, as in a fresh clone)
# and the type-debt counts, which may only fall
MYPY       := $(BIN)/python -m mypy -n $(WORKERS)
test: $(STAMP)
	$(BIN)/ruff check src tests benchmarks tools docs examples
	$(BIN)/python -m pytest -m "not slow and not long" -q $(XDIST)
	$(MYPY)
	$(BIN)/python tools/type_debt.py

# The long tier: tests of 3 s or more each and the tiny `reproduce` run's (the marker `long`,
# pyproject.toml); CI runs it after `make test`
test-long: $(STAMP)
	$(BIN)/python -m pytest -m "long and not slow" -q $(XDIST)

# The tests against stored references, as if on another CPU: NumPy, glibc, XLA, OpenBLAS and numba
# limited to an older instruction set (tools/other_isa.py checks that each one took notice).
test-other-isa: $(STAMP)
	$(BIN)/python tools/other_isa.py check
	$(BIN)/python tools/other_isa.py run -- $(BIN)/python -m pytest -m "reference and not slow" -q

# The documentation site into docs/_build/html (git-ignored), offline, warnings as errors: the
# pages of docs/, the API reference written from the docstrings, the command-line reference and
# the example gallery of examples/ (every script runs; rerun only when changed).
docs: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -m sphinx -b html -W --keep-going -q docs docs/_build/html
	@echo "the site: docs/_build/html/index.html"

test-slow: $(STAMP)
	$(BIN)/python -m pytest -m slow -q

test-all: test test-long test-slow

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks tools docs examples
	$(MYPY)
	$(BIN)/python tools/type_debt.py

bench: $(STAMP)
	for f in benchmarks/*.py; do case $$f in */compare_checkouts.py|*/fidelity.py|*/nss_kernel.py|\
		*/fill_levels.py|*/multimode.py|*/bouncing_ball.py|*/peer_subnet.py|\
		*/noe_passive.py) continue;; esac; \
		$(BIN)/python $$f || exit 1; done

# Beyond the paper: one `reproduce --beyond` run, then the figures of its three studies.
beyond: $(STAMP)
	$(BIN)/python benchmarks/fill_levels.py --out bench_beyond
	$(BIN)/python benchmarks/multimode.py --summary bench_beyond/summary.json
	$(BIN)/python benchmarks/bouncing_ball.py --run bench_beyond --no-pipeline

# The ROM's fidelity targets: three full `reproduce` runs (default, rig B, the paper's recipe).
fidelity: $(STAMP)
	$(BIN)/python benchmarks/fidelity.py --out bench_fidelity

# A peer in the same run: deepSI's SUBNET trained on the records of `make reproduce` (results/),
# scored like our ROM (validation fit, Phi_d map against the rig's), 10 min of training. Its own
# venv, not a dependency of the package: torch first and alone (==2.13.0 takes the machine's
# CPU build; another request would pull CUDA wheels), then deepSI pinned with hashes, then our
# lock exactly as in .venv.
$(PEERS)/.installed: $(PEERS_LOCK) $(LOCK) pyproject.toml
	test -x $(PEERS)/bin/python || $(PYTHON) -m venv $(PEERS)
	$(PEERS)/bin/python -m pip install --quiet --no-deps torch==2.13.0
	$(PEERS)/bin/python -m pip install --quiet --require-hashes -r $(PEERS_LOCK)
	$(PEERS)/bin/python -m pip install --quiet --require-hashes --no-deps -r $(LOCK)
	$(PEERS)/bin/python -m pip install --quiet --no-deps --no-build-isolation -e .
	$(PEERS)/bin/python -m pip check
	touch $@

# (checked before the venv is built: the peer needs a finished `make reproduce`)
peers:
	@test -f results/summary.json || { echo "make peers: no results/summary.json: run \
	'make reproduce' first (the peer trains on its records and is scored beside its ROM)"; \
	exit 1; }
	$(MAKE) --no-print-directory $(PEERS)/.installed
	$(PEERS)/bin/python benchmarks/peer_subnet.py --run results --out results/peer_subnet.json

# The damping uncertainty against pyOMA-2's SSI-cov with its own uncertainty (its environment,
# never .venv: pyOMA-2 is a benchmark peer, not a dependency)
$(PYOMA)/.installed: $(PYOMA_LOCK) $(LOCK) pyproject.toml
	test -x $(PYOMA)/bin/python || $(PYTHON) -m venv $(PYOMA)
	$(PYOMA)/bin/python -m pip install --quiet --require-hashes -r $(PYOMA_LOCK)
	$(PYOMA)/bin/python -m pip install --quiet --require-hashes --no-deps -r $(LOCK)
	$(PYOMA)/bin/python -m pip install --quiet --no-deps --no-build-isolation -e .
	$(PYOMA)/bin/python -m pip check
	touch $@

pyoma: $(PYOMA)/.installed
	$(PYOMA)/bin/python benchmarks/pyoma_crosscheck.py

# Refresh the lock (pinned uv in its own venv; one version set for CPython 3.11+ on every OS).
lock:
	test -x $(TOOLS)/bin/uv || ($(PYTHON) -m venv $(TOOLS) && \
		$(TOOLS)/bin/python -m pip install --quiet --require-hashes --no-deps -r $(UV_LOCK))
	$(TOOLS)/bin/uv pip compile pyproject.toml tools/build-requirements.in --extra dev --extra docs \
		--generate-hashes --universal --fork-strategy fewest --python-version 3.11 \
		--quiet -o $(LOCK)
	@echo "wrote $(LOCK); run 'make test' to install and test it"

# Scheduled-style check: a fresh venv with the newest releases the ranges allow; prints every
# package that differs from the lock (the names to look at when this fails), then the tests.
test-latest:
	rm -rf $(LATEST)
	$(PYTHON) -m venv $(LATEST)
	$(LATEST)/bin/python -m pip install --quiet --upgrade pip
	$(LATEST)/bin/python -m pip install --quiet --upgrade --upgrade-strategy eager \
		-r tools/build-requirements.in -e '.[dev]'
	$(LATEST)/bin/python tools/lock_diff.py $(LOCK)
	$(LATEST)/bin/python -m pytest -m "not slow" -q $(XDIST)

clean:
	rm -rf $(VENV) $(TOOLS) $(LATEST) $(PYOMA) results .pytest_cache .mypy_cache \
		docs/_build docs/api docs/auto_examples docs/sg_execution_times.rst build dist
