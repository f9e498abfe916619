from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import pyarrow.parquet as pq
from click.testing import CliRunner

from flylog.cli.main import cli
from flylog.metrics.score import score_run
from flylog.sweep.cells import sweep_cells
from flylog.sweep.results import TIMING_COLUMNS, read_results
from flylog.sweep.runner import SweepResult
from flylog.sweep.spec import load_spec
from flylog.sweep.summary import summarize

from .conftest import NEAR, SPEC, write_spec


def test_one_row_per_cell_ok_and_failed(pool_sweep: SweepResult) -> None:
    rows = pool_sweep.rows
    assert [r["cell"] for r in rows] == list(range(8))
    assert [(r["engine.flies"], r["seed"]) for r in rows[:4]] == [
        (96, 0),
        (96, 1),
        (160, 0),
        (160, 1),
    ]
    good, bad = rows[:4], rows[4:]
    assert all(r["status"] == "ok" and r["error"] is None for r in good)
    assert all(r["input"] == str(NEAR) and r["input_kind"] == "log" for r in good)
    assert all(r["status"] == "failed" and "bad.mcap" in r["error"] for r in bad)
    assert all(r["precision"] is None and r["snapshots"] is None for r in bad)
    # the row holds what flylog metrics says of the cell's run, seeds differ
    out = pool_sweep.results.parent
    first = score_run(out / good[0]["run_dir"] / "run.mcap", NEAR, pool_sweep.spec.metrics)
    assert first.summary["precision"] == good[0]["precision"]
    assert first.summary["generations"] == good[0]["generations"] == 16  # one per pair
    assert good[0]["fingerprint"] != good[1]["fingerprint"]
    assert good[0]["evaluations"] != good[1]["evaluations"]  # the engine seed matters


def test_results_table_documents_its_columns(pool_sweep: SweepResult) -> None:
    keys, rows = read_results(pool_sweep.results.parent)
    assert keys == ["engine.flies"] and len(rows) == 8
    kv = pq.ParquetFile(pool_sweep.results).metadata.metadata
    columns = json.loads(kv[b"flylog.columns"])
    assert list(columns) == pq.read_schema(pool_sweep.results).names
    assert columns["cell_wall_s"]["unit"] == "s"
    assert columns["engine.flies"]["description"].startswith("grid key: population size")
    assert columns["min_clearance_m"] == {
        "unit": "m",
        "description": "least distance to an obstacle minus the robot radius",
    }


def test_summary_per_grid_point(pool_sweep: SweepResult) -> None:
    points = summarize(pool_sweep.rows, ["engine.flies"], ["precision"])
    assert [p.key for p in points] == [
        (("variant", "per-frame"), ("engine.flies", 96)),
        (("variant", "per-frame"), ("engine.flies", 160)),
    ]
    assert all((p.ok, p.failed) == (2, 2) for p in points)
    mean, sd = points[0].metrics["precision"]
    a, b = (r["precision"] for r in pool_sweep.rows[:2])
    assert math.isclose(mean, (a + b) / 2) and math.isclose(sd, abs(a - b) / math.sqrt(2))


def test_resume_reruns_only_failed_cells_and_exits_1(
    pool_sweep: SweepResult, tiny_spec: Path, tmp_path: Path
) -> None:
    out = tmp_path / "sweep"
    shutil.copytree(pool_sweep.results.parent, out)
    got = CliRunner().invoke(cli, ["sweep", str(tiny_spec), "-o", str(out), "--workers", "1"])
    assert got.exit_code == 1, got.output
    assert "8 cells (4 run, 4 already done)" in got.output
    assert got.output.count("failed:") == 4 and "bad.mcap" in got.output
    _, rows = read_results(out)
    assert rows[:4] == read_results(pool_sweep.results)[1][:4]  # read back from cell.json


def test_fingerprints_follow_input_content_and_configuration(tmp_path: Path) -> None:
    log = tmp_path / "near.mcap"
    shutil.copyfile(NEAR, log)
    spec_path = write_spec(tmp_path, SPEC.format(log=log).replace(', "bad.mcap"', ""))
    first = [c.fingerprint for c in sweep_cells(load_spec(spec_path), tmp_path, [])]
    assert first == [c.fingerprint for c in sweep_cells(load_spec(spec_path), tmp_path, [])]
    assert len(set(first)) == 4
    changed = SPEC.format(log=log).replace(', "bad.mcap"', "").replace("15.0", "5.0")
    changed_spec = load_spec(write_spec(tmp_path, changed))
    other = [c.fingerprint for c in sweep_cells(changed_spec, tmp_path, [])]
    assert not set(other) & set(first)
    with log.open("ab") as fh:
        fh.write(b"\0")
    moved = [c.fingerprint for c in sweep_cells(load_spec(spec_path), tmp_path, [])]
    assert not set(moved) & set(first)


def test_bad_spec_exits_2_and_writes_nothing(tmp_path: Path) -> None:
    spec = write_spec(tmp_path, "seeds = [0]\ncolour = 1\n")
    got = CliRunner().invoke(cli, ["sweep", str(spec), "-o", str(tmp_path / "out")])
    assert got.exit_code == 2
    assert "unknown field 'colour'" in got.output and "no inputs" in got.output
    assert not (tmp_path / "out").exists()


def timing_free(rows: list[dict]) -> list[dict]:
    return [{k: v for k, v in r.items() if k not in TIMING_COLUMNS} for r in rows]
