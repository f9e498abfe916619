# Two commands on a fresh machine with Python 3.11: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
DEMO_STAMP := $(VENV)/.installed-package
DEMO_DIR := demo-out

.PHONY: demo test lint bench fuzz fixtures experiments docs clean bytecode confidence

# `make test`'s environment: flylog and its test extras (pytest, ruff, mypy, Ray, ...).
$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	$(MAKE) bytecode
	touch $(STAMP) $(DEMO_STAMP)

# `make demo`'s: flylog alone (its test extras, Ray above all, are most of the first's size).
$(DEMO_STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e .
	$(MAKE) bytecode
	touch $(DEMO_STAMP)

# pip byte-compiles what it installs, but not an editable install's sources: with
# PYTHONDONTWRITEBYTECODE set (as in many containers) every command would compile flylog's
# ~100 modules again (0.09 s of `flylog replay`'s start). Python recompiles in memory any
# module edited since; `make bytecode` refreshes them.
bytecode:
	$(BIN)/python -m compileall -q flylog cli

demo: $(DEMO_STAMP)
	$(BIN)/python -m flylog.cli.demo $(DEMO_DIR)

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy

test: lint
	$(BIN)/python -m pytest -q

bench: $(STAMP)
	$(BIN)/python -m tests.benchmarks

# The reader on 12,000 seeded mutants: 5,000 of a one-chunk fixture, 5,000 of its copy in lz4
# chunks of 64 KiB (17 chunks), 1,000 of that copy with whole chunks deleted and 1,000 of its
# ROS 2 export read as a bag; two worker processes, 5 s a mutant (docs/log-integrity.md).
fuzz: $(STAMP)
	$(BIN)/python -m tests.io.fuzz fixtures/logs/near-obstacle.mcap --lz4-copy 65536 \
		--mutants 5000 --chunk-deletions 1000 --bag-mutants 1000 --workers 2

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

# flylog/fly/confidence.json from simulated runs (docs/export.md#confidence): 8 s at 320x240,
# the default configuration; fitted on corridor, turn, doorways seeds 0-1, checked on
# clutter seeds 5 and 6, near-obstacle seed 5 and corridor seed 5. A test checks the file is
# current for the default configuration.
CONFIDENCE_DIR ?= confidence-runs
CONFIDENCE_FIT := corridor:0 turn:0 doorways:0 corridor:1 turn:1 doorways:1
CONFIDENCE_HELD_OUT := clutter:5 near-obstacle:5 corridor:5 clutter:6
confidence: $(STAMP)
	mkdir -p $(CONFIDENCE_DIR)
	for spec in $(CONFIDENCE_FIT) $(CONFIDENCE_HELD_OUT); do \
		scene=$${spec%%:*}; seed=$${spec##*:}; n=$(CONFIDENCE_DIR)/$$scene-$$seed; \
		test -f $$n.run.mcap || { \
		$(BIN)/flylog simulate fixtures/scenes/$$scene.toml --duration 8 --resolution 320x240 \
			--seed $$seed -o $$n.mcap && \
		$(BIN)/flylog replay $$n.mcap --seed $$seed -o $$n.run.mcap; } || exit 1; \
	done
	cd $(CONFIDENCE_DIR) && $(CURDIR)/$(BIN)/flylog calibrate \
		$(foreach s,$(CONFIDENCE_FIT),--fit $(subst :,-,$(s)).run.mcap $(subst :,-,$(s)).mcap) \
		$(foreach s,$(CONFIDENCE_HELD_OUT),--held-out $(subst :,-,$(s)).run.mcap $(subst :,-,$(s)).mcap) \
		-o $(CURDIR)/flylog/fly/confidence.json

clean:
	rm -rf $(VENV) $(DEMO_DIR) .pytest_cache
	find flylog cli -name "*.nb[ic]" -delete  # numba caches
