from __future__ import annotations

from pathlib import Path

from flylog.sweep.runner import SweepOptions, run_sweep

from .conftest import LOGS, write_spec

SCENE = LOGS.parent / "scenes" / "near-obstacle.toml"

SPEC = f"""
seeds = [0]
[[simulate]]
scene = "{SCENE}"
duration = 0.5
resolution = [64, 48]
seeds = [3]
[[simulate]]
scene = "{SCENE}"
duration = 0.5
resolution = [64, 48]
seeds = [3]
drive = "planner"
[[variants]]
name = "small"
generations_per_frame = 1
engine.flies = 64
"""


def test_simulated_then_replayed_and_closed_loop_cells(tmp_path: Path) -> None:
    out = tmp_path / "sweep"
    spec = write_spec(tmp_path, SPEC)
    result = run_sweep(spec, out, SweepOptions(workers=1))
    replayed, closed = result.rows
    assert [r["status"] for r in result.rows] == ["ok", "ok"], [r["error"] for r in result.rows]
    assert (replayed["input_kind"], closed["input_kind"]) == ("simulate", "closed_loop")
    assert replayed["input"] == closed["input"] == f"{SCENE}@seed3"
    assert replayed["input_seed"] == closed["input_seed"] == 3
    (log,) = (out / "inputs").glob("*.mcap")
    assert log.with_suffix(".json").is_file()
    # the closed loop drives by the planner: its log holds the run, scored against itself
    assert closed["generations"] == replayed["generations"] == 8  # one per pair, 0.5 s
    assert closed["path_length_m"] != replayed["path_length_m"]
    # a second run simulates nothing and runs nothing
    again = run_sweep(spec, out, SweepOptions(workers=1))
    assert (again.ran, again.reused) == (0, 2)
