# millstab: the commands a newcomer needs are `make demo`, `make test` and `make app`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
WARM := $(VENV)/.warm

.PHONY: demo test test-fast app bench clean warmup

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e ".[test,dask]"
	touch $(STAMP)

# the engines compiled into numba's cache once, right after installing (a fresh install otherwise compiles
# each engine at its first use, for minutes), two processes side by side; `make test` waits for it too: every
# pytest-xdist worker that meets an uncompiled engine compiles it itself (on a cold cache two workers spent 1.8x
# the CPU of one on the same spectral tests), so compiling each once first saves the duplicate
WARM_JOBS ?= 2
$(WARM): $(STAMP)
	@echo "compiling the engines into the cache (first install only; a minute or two)"
	$(BIN)/millstab warmup --jobs $(WARM_JOBS)
	touch $(WARM)

## warmup: compile every engine into the cache (demo and app do this first)
warmup: $(WARM)

## demo: install into .venv, reproduce the seed paper into ./millstab-report (open report.html)
demo: $(WARM)
	$(BIN)/millstab reproduce --out millstab-report
	@echo "open millstab-report/report.html"

# the tests run in one process per core (pytest-xdist; `worksteal` hands the long tests out first): the suite is
# CPU-bound and single-threaded, so on CI's 2 cores this halves its wall time; PYTEST_WORKERS=0 runs it serially
PYTEST_WORKERS ?= auto
PYTEST := $(BIN)/python -m pytest -q -n $(PYTEST_WORKERS) --dist worksteal

## test: install into .venv and run the test suite
test: $(WARM)
	$(PYTEST)

## test-fast: the inner loop: every test not marked slow (1 805 tests, 3 min 32 s on 2 cores after `make demo` compiled the engines)
test-fast: $(WARM)
	$(PYTEST) -m "not slow"

## app: install the app extra into .venv and serve the browser interface on http://127.0.0.1:5006/
app: $(WARM)
	$(BIN)/python -m pip install -q -e ".[app]"
	$(BIN)/millstab app

## bench: print the speed figures (envelope throughput, SDM, identification, Monte Carlo)
bench: $(STAMP)
	$(BIN)/python benchmarks/bench_envelope.py
	$(BIN)/python benchmarks/bench_sdm.py
	$(BIN)/python benchmarks/bench_identify.py
	$(BIN)/python benchmarks/bench_sensitivity.py
	$(BIN)/python benchmarks/bench_app.py

clean:
	rm -rf $(VENV) millstab-report .pytest_cache .numba_cache
