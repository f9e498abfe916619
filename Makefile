# Two commands on a fresh machine with Python 3.11: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
DEMO_DIR := demo-out

.PHONY: demo test lint bench fuzz fixtures experiments docs clean bytecode

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	$(MAKE) bytecode
	touch $(STAMP)

# pip byte-compiles what it installs, but not an editable install's sources: with
# PYTHONDONTWRITEBYTECODE set (as in many containers) every command would compile flylog's
# ~100 modules again (0.09 s of `flylog replay`'s start). Python recompiles in memory any
# module edited since; `make bytecode` refreshes them.
bytecode:
	$(BIN)/python -m compileall -q flylog cli

demo: $(STAMP)
	$(BIN)/python -m flylog.cli.demo $(DEMO_DIR)

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy

test: lint
	$(BIN)/python -m pytest -q

bench: $(STAMP)
	$(BIN)/python -m tests.benchmarks

# The reader on 10,000 seeded mutants: 5,000 of a one-chunk fixture and 5,000 of its copy in
# lz4 chunks of 64 KiB (17 chunks), two worker processes, 5 s a mutant (docs/log-integrity.md).
fuzz: $(STAMP)
	$(BIN)/python -m tests.io.fuzz fixtures/logs/near-obstacle.mcap --lz4-copy 65536 \
		--mutants 5000 --workers 2

# docs/experiments/ as committed: three experiments at their defaults, the closed loop with
# 10 seeds; each command runs its cells on a pool of all the cores (docs/experiments/README.md).
experiments: $(STAMP)
	$(BIN)/flylog experiment proprioception -o docs/experiments
	$(BIN)/flylog experiment sonar -o docs/experiments
	$(BIN)/flylog experiment latency -o docs/experiments
	$(BIN)/flylog experiment closed-loop --seeds 10 -o docs/experiments
	$(BIN)/flylog experiment navigation -o docs/experiments

# docs/configuration.md and the table schemas in docs/metrics.md, from the code (a test
# checks they are current).
docs: $(STAMP)
	$(BIN)/python -m flylog.reference_docs docs

fixtures: $(STAMP)
	$(BIN)/python fixtures/regenerate.py

clean:
	rm -rf $(VENV) $(DEMO_DIR) .pytest_cache
	find flylog cli -name "*.nb[ic]" -delete  # numba caches
