"""The experiments' cells on the sweep's process pool write, byte for byte, the same files
on one worker and on two (virtual clock, seeded runs); and their rows are those of the
per-seed functions called directly in this process."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import pytest

from flylog.experiments import experiment_plan, proprioception, sonar
from flylog.experiments.cells import ExperimentCell, run_cell
from flylog.experiments.common import ExperimentOptions
from flylog.experiments.parallel import run_experiments
from flylog.sweep.order import longest_first_order

TINY = ExperimentOptions(seeds=2, resolution=(48, 36), duration=0.4, flies=64)
NAMES = ["sonar", "proprioception"]


def _json_numbers(row: dict) -> dict:
    """A row as results.json holds it: NaN as null."""
    return {k: None if isinstance(v, float) and math.isnan(v) else v for k, v in row.items()}


def _outputs(directory: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(directory)): p.read_bytes()
        for p in sorted(directory.rglob("*"))
        if p.is_file()
    }


PROGRESS: list[tuple[float, float]] = []


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> dict[str, Path]:
    out = {}
    for workers in (1, 2):
        out[f"pool of {workers}"] = tmp_path_factory.mktemp(f"pool{workers}")
        run_experiments(
            NAMES, out[f"pool of {workers}"], TINY, workers=workers,
            on_progress=(lambda d, t: PROGRESS.append((d, t))) if workers == 2 else None,
        )  # fmt: skip
    return out


def test_every_worker_count_writes_the_same_bytes(written: dict[str, Path]) -> None:
    one = _outputs(written["pool of 1"])
    assert sorted(one) == sorted(
        f"{name}/{file}"
        for name in NAMES
        for file in ("curves.png", "frames.png", "map.png", "results.json", "summary.md")
    )
    assert _outputs(written["pool of 2"]) == one


def test_rows_are_those_of_the_per_seed_functions(written: dict[str, Path], tmp_path) -> None:
    """Each seed's cell function called directly gives the rows results.json holds."""
    for module, name in ((sonar, "sonar"), (proprioception, "proprioception")):
        plan = experiment_plan(name, tmp_path, TINY)
        direct = []
        for seed, cell in enumerate(plan.cells):
            assert cell.task.seed == seed
            direct += module._run_seed(cell.task).runs
        saved = json.loads((written["pool of 2"] / name / "results.json").read_text())
        assert [(r["configuration"], r["seed"]) for r in saved["runs"]] == [
            (c, s) for s in range(TINY.seeds) for c in module.CONFIGS
        ]
        assert [_json_numbers(r) for r in direct] == saved["runs"]


def test_progress_counts_the_expected_work_of_every_cell(
    written: dict[str, Path], tmp_path: Path
) -> None:
    """Each finished cell adds its expected work (log seconds), so the bar's ETA weighs a
    long cell as long; the total is every experiment's cells' work."""
    works = [c.work for name in NAMES for c in experiment_plan(name, tmp_path, TINY).cells]
    assert len(PROGRESS) == 1 + len(works) == 1 + 2 * TINY.seeds
    assert {t for _, t in PROGRESS} == {sum(works)}
    done = [d for d, _ in PROGRESS]
    assert done[0] == 0.0 and done == sorted(done) and done[-1] == pytest.approx(sum(works))
    steps = sorted(round(b - a, 9) for a, b in itertools.pairwise(done))
    assert steps == sorted(round(w, 9) for w in works)


def test_cells_go_out_longest_first_ties_in_order() -> None:
    assert longest_first_order([1.0, 3.0, 2.0, 3.0]) == [1, 3, 2, 0]


def test_an_error_in_a_cell_names_the_experiment_and_the_cell() -> None:
    cell = ExperimentCell("sonar", "near-obstacle, seed 3", 1.0, math.sqrt, -1.0)
    with pytest.raises(ValueError, match="math domain error") as caught:
        run_cell(cell)
    assert caught.value.__notes__ == ["in the sonar experiment's cell near-obstacle, seed 3"]
