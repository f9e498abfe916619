"""A cell whose input lost messages says so in results.parquet, and compare says so too."""

from __future__ import annotations

from pathlib import Path

from click.testing import CliRunner

from flylog.cli.main import cli
from flylog.sweep.cells import sweep_cells
from flylog.sweep.results import RESULTS_NAME, cell_row, read_results, write_results
from flylog.sweep.spec import load_spec
from flylog.sweep.work import run_cell
from tests.io.fuzz import rechunked
from tests.io.mutate import record_spans

from .conftest import NEAR, write_spec

SPEC = """
logs = ["{log}"]
seeds = [0]
[[variants]]
name = "per-frame"
generations_per_frame = 1
snapshot_rate = 5.0
"engine.flies" = 96
"""


def _without_second_chunk(tmp_path: Path) -> Path:
    copy = rechunked(NEAR, tmp_path / "five.mcap", chunk_size=100_000)
    data = copy.read_bytes()
    chunks = [(a, b) for a, b in record_spans(data) if data[a] == 0x06]
    assert len(chunks) >= 5
    a, b = chunks[1]
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(data[:a] + data[b:])
    return damaged


def test_a_cell_on_a_damaged_log_counts_what_it_lost(tmp_path):
    log = _without_second_chunk(tmp_path)
    spec = load_spec(write_spec(tmp_path, SPEC.format(log=log)))
    out = tmp_path / "sweep"
    (cell,) = sweep_cells(spec, out, [])
    row = run_cell(cell)
    assert row["status"] == "ok"
    assert row["input_messages_lost"] > 0
    assert "lost" in row["input_warnings"] and str(log) in row["input_warnings"]
    results = out / RESULTS_NAME
    write_results(results, spec.grid, [cell_row(cell, row, out)], spec.source)
    (written,) = read_results(results)[1]
    assert written["input_messages_lost"] == row["input_messages_lost"]
    result = CliRunner().invoke(cli, ["compare", str(results), str(results)])
    assert "input damaged" in result.output and "input messages lost" in result.output


def test_an_intact_input_has_none(tmp_path):
    from flylog.sweep.work import input_damage

    assert input_damage([]) == {"input_messages_lost": 0, "input_warnings": ""}
