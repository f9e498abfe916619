# Two commands on a fresh machine with Python 3.11: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
DEMO_DIR := demo-out

.PHONY: demo test lint bench fixtures experiments docs clean bytecode

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

experiments: $(STAMP)
	$(BIN)/flylog experiment all -o docs/experiments

# docs/configuration.md and the table schemas in docs/metrics.md, from the code (a test
# checks they are current).
docs: $(STAMP)
	$(BIN)/python -m flylog.reference_docs docs

fixtures: $(STAMP)
	$(BIN)/python fixtures/regenerate.py

clean:
	rm -rf $(VENV) $(DEMO_DIR) .pytest_cache
	find flylog cli -name "*.nb[ic]" -delete  # numba caches
