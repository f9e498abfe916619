"""The experiments' cells on the sweep's process pool write, byte for byte, the same files
on one worker and on two (virtual clock, seeded runs); and their rows are those of the
per-seed functions called directly in this process."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import pytest

from flylog.experiments import experiment_plan, proprioception, sonar
from flylog.experiments.cell_progress import stage
from flylog.experiments.cells import ExperimentCell, ExperimentPlan, run_cell
from flylog.experiments.common import ExperimentOptions, ExperimentResult, Table
from flylog.experiments.parallel import run_experiments, run_plans, run_plans_serially
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
            NAMES,
            out[f"pool of {workers}"],
            TINY,
            workers=workers,
            on_progress=(lambda d, t: PROGRESS.append((d, t))) if workers == 2 else None,
        )
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
    """The bar's figure is the cells' expected work (log seconds), so its ETA weighs a long
    cell as long: it starts at 0, never goes back, and ends at every cell's work."""
    works = [c.work for name in NAMES for c in experiment_plan(name, tmp_path, TINY).cells]
    assert {t for _, t in PROGRESS} == {sum(works)}
    done = [d for d, _ in PROGRESS]
    assert done[0] == 0.0 and done == sorted(done) and done[-1] == pytest.approx(sum(works))
    assert len(done) >= 1 + len(works)


def _slow_cell(seconds: float) -> float:
    """A cell that reports its log seconds as a replay would, over about 1.5 s."""
    update = stage()
    assert update is not None
    for k in range(6):
        update(k * seconds / 5, seconds)
        time.sleep(0.3)
    return seconds


def _results_as_runs(results: list[float]) -> ExperimentResult:
    return ExperimentResult(
        "slow", Table("", (), ()), Path(), (), tuple({"seconds": r} for r in results)
    )


@pytest.mark.parametrize("pool", [True, False], ids=["pool", "this process"])
def test_progress_moves_within_a_running_cell(pool: bool) -> None:
    """The cell reports while it runs: the bar shows a figure between 0 and the cell's
    work before the cell ends, from a pool's worker and in this process."""
    cell = ExperimentCell("slow", "one", 10.0, _slow_cell, 10.0)
    plan = ExperimentPlan("slow", (cell,), _results_as_runs)
    seen: list[float] = []

    def update(done: float, total: float) -> None:
        assert total == 10.0
        seen.append(done)

    if pool:
        results = run_plans([plan], workers=1, on_progress=update)
    else:
        results = run_plans_serially([plan], on_progress=update)
    assert [r.runs for r in results] == [({"seconds": 10.0},)]
    assert seen == sorted(seen) and seen[0] == 0.0 and seen[-1] == 10.0
    assert any(0.0 < d < 10.0 for d in seen)


def test_a_cell_outside_a_pool_reports_nowhere() -> None:
    assert stage() is None


def test_cells_go_out_longest_first_ties_in_order() -> None:
    assert longest_first_order([1.0, 3.0, 2.0, 3.0]) == [1, 3, 2, 0]


def test_an_error_in_a_cell_names_the_experiment_and_the_cell() -> None:
    cell = ExperimentCell("sonar", "near-obstacle, seed 3", 1.0, math.sqrt, -1.0)
    with pytest.raises(ValueError, match="math domain error") as caught:
        run_cell(cell)
    assert caught.value.__notes__ == ["in the sonar experiment's cell near-obstacle, seed 3"]
