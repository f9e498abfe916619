"""Experiments run at once in the sweep's process pool give what they give one after the
other in this process (virtual clock, seeded runs)."""

from __future__ import annotations

import json
from pathlib import Path

from flylog.experiments import EXPERIMENTS, run_experiment
from flylog.experiments.common import ExperimentOptions
from flylog.experiments.parallel import LONGEST_FIRST, run_experiments

TINY = ExperimentOptions(seeds=1, resolution=(48, 36), duration=0.4, flies=64)
NAMES = ["sonar", "proprioception"]


def test_two_experiments_at_once_equal_them_one_after_the_other(tmp_path: Path) -> None:
    done: list[tuple[str, int, int]] = []
    parallel = run_experiments(
        NAMES, tmp_path / "pool", TINY, workers=2,
        on_done=lambda r, d, t: done.append((r.name, d, t)),
    )  # fmt: skip
    assert [r.name for r in parallel] == NAMES
    assert sorted(d for _, d, _ in done) == [1, 2] and {n for n, _, t in done} == set(NAMES)
    for name, got in zip(NAMES, parallel, strict=True):
        alone = run_experiment(name, tmp_path / "serial", TINY)
        assert len(got.runs) == len(alone.runs) == 2  # two configurations, one seed
        pool_json = json.loads((tmp_path / "pool" / name / "results.json").read_text())
        serial_json = json.loads((tmp_path / "serial" / name / "results.json").read_text())
        assert pool_json == serial_json  # every run's figures (NaN as null), the table


def test_every_experiment_has_its_place_in_the_order() -> None:
    assert sorted(LONGEST_FIRST) == sorted(EXPERIMENTS)
