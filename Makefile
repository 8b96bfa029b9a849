# Two entry points: `make run` (set up, migrate, serve) and `make test` (set up, lint, test).
PY      ?= python3
VENV    := .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.installed
RUN_STAMP := $(VENV)/.installed-run
# `make run HOST=0.0.0.0 PORT=9000` serves elsewhere (the defaults: this machine only, 8000).
HOST    ?= 127.0.0.1
PORT    ?= 8000

.PHONY: run test lint format browser postgresql bench reproduce results clean

$(BIN)/pip:
	$(PY) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip

# What serving needs: the package and the experiments extra (matplotlib, Dask): the server
# starts sweeps.
$(RUN_STAMP): pyproject.toml | $(BIN)/pip
	$(BIN)/pip install --quiet -e '.[experiments]'
	touch $(RUN_STAMP)

# Everything for `make test`: `.[dev]` adds the test, lint and type-check tools (and
# PostgreSQL's driver: the API suite runs on PostgreSQL too). It includes the run set.
$(STAMP): pyproject.toml | $(BIN)/pip
	$(BIN)/pip install --quiet -e '.[dev]'
	touch $(STAMP) $(RUN_STAMP)

run: $(RUN_STAMP)
	$(BIN)/regolith db upgrade
	$(BIN)/regolith serve --host $(HOST) --port $(PORT)

# Debian's chromium for the browser tests; only root can apt-get, others get a skip message.
browser:
	@if [ ! -x /usr/bin/chromium ] && [ "$$(id -u)" = "0" ]; then \
		apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null; \
	fi

# Debian's PostgreSQL server binaries (initdb, pg_ctl) for the API suite's PostgreSQL half;
# only root can apt-get, others get a skip message (CI, as root, must have them).
postgresql:
	@if ! ls /usr/lib/postgresql/*/bin/initdb >/dev/null 2>&1 && [ "$$(id -u)" = "0" ]; then \
		apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq postgresql >/dev/null; \
	fi

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy engine field
	$(BIN)/lint-imports

# Three workers (pytest-xdist) on this two-core machine: part of the suite waits on servers,
# browsers and PostgreSQL, and a third worker fills those waits (docs/benchmarks.md, Test
# suite); each worker has its own free ports, temporary folders and cluster.
TEST_WORKERS ?= 3

# Field missions (tests marked `fleet`: twelve agent processes each, at 50-100x wall-clock
# speed) run after the rest, alone on the machine: starved of CPU, their robots would miss
# timeouts that are a few wall milliseconds long.
test: $(STAMP) browser postgresql lint
	$(BIN)/pytest -q -n $(TEST_WORKERS) --dist worksteal -m "not fleet"
	$(BIN)/pytest -q -m fleet

format: $(STAMP)
	$(BIN)/ruff format .
	$(BIN)/ruff check --fix .

bench: $(STAMP)
	$(BIN)/python bench/engine_bench.py

# Rerun every experiment docs/experiments.md and docs/policies.md cite, from scratch, into a
# temporary folder, and check every generated number in them (and results/*/runs.csv)
# against the fresh run. Not part of CI (~minutes on 2 cores; docs/experiments.md).
reproduce: $(STAMP)
	nice $(BIN)/python -m experiments.reproduce

# The same experiments (resumable in sweeps/reproduce/), then rewrite results/, the docs'
# generated blocks and their figures from them.
results: $(STAMP)
	nice $(BIN)/python -m experiments.reproduce --write

clean:
	rm -rf $(VENV) .mypy_cache .ruff_cache .pytest_cache .import_linter_cache
