from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from flylog.cli.main import cli
from flylog.sweep.compare import compare_results
from flylog.sweep.results import read_results, write_results
from flylog.sweep.runner import SweepResult


def _candidate(pool_sweep: SweepResult, tmp_path: Path) -> Path:
    """The pool sweep's rows with precision 0.2 lower at 160 flies."""
    _, rows = read_results(pool_sweep.results)
    for r in rows:
        if r["engine.flies"] == 160 and r["precision"] is not None:
            r["precision"] -= 0.2
    path = tmp_path / "results.parquet"
    write_results(path, pool_sweep.spec.grid, rows, pool_sweep.spec.source)
    return path


def test_rows_are_matched_by_grid_point(pool_sweep: SweepResult, tmp_path: Path) -> None:
    got = compare_results(pool_sweep.results, _candidate(pool_sweep, tmp_path))
    assert [g.key for g in got.groups] == [
        (("variant", "per-frame"), ("engine.flies", 96)),
        (("variant", "per-frame"), ("engine.flies", 160)),
    ]
    same, worse = got.groups
    assert (same.comparison.n_base, same.failed_base, same.failed_candidate) == (2, 2, 2)
    assert not same.comparison.regressed
    assert [m.name for m in worse.comparison.regressed] == ["precision"]
    names = {m.name for m in same.comparison.metrics}
    assert "seed" not in names and "cell" not in names and "f_score" in names


def test_cli_json_of_two_sweeps(pool_sweep: SweepResult, tmp_path: Path) -> None:
    cand = _candidate(pool_sweep, tmp_path)
    got = CliRunner().invoke(cli, ["compare", str(pool_sweep.results), str(cand), "--json"])
    assert got.exit_code == 1
    report = json.loads(got.stdout)
    assert report["regressions"] == ["variant=per-frame, engine.flies=160: precision"]
    assert [g["key"] for g in report["groups"]] == [
        {"variant": "per-frame", "engine.flies": 96},
        {"variant": "per-frame", "engine.flies": 160},
    ]
    same = CliRunner().invoke(cli, ["compare", str(pool_sweep.results), str(pool_sweep.results)])
    assert same.exit_code == 0 and "engine.flies=160" in same.output
