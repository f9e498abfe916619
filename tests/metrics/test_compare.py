import math
from pathlib import Path

import pytest
from click.testing import CliRunner

from flylog.cli.compare import compare as compare_command
from flylog.errors import ConfigError, LogError
from flylog.metrics import tables
from flylog.metrics.compare import (
    DEFAULT_TOLERANCES,
    Direction,
    Tolerance,
    Verdict,
    compare_files,
    compare_summaries,
    judge,
    load_tolerances,
    mean_std,
    override_tolerance,
)

BASE = {"precision": 0.80, "ate_m": 0.10, "goal_reached": True, "collisions": 0, "wall_s": 9.0}


def write_summary(path: Path, **values) -> Path:
    """A metrics output NAME.parquet whose summary holds BASE updated with ``values``."""
    row = {c.name: None for c in tables.SUMMARY_COLUMNS}
    row.update(BASE, run="run.mcap", log="log.mcap", **values)
    tables.write_table(tables.summary_path(path), tables.SUMMARY_COLUMNS, [row], {})
    return path


def by_name(result):
    return {m.name: m for m in result.metrics}


def test_judge_both_directions_and_tolerance_kinds():
    hi = Tolerance(Direction.HIGHER, absolute=0.02)
    assert judge(0.80, 0.79, hi) == (0.02, Verdict.OK)
    assert judge(0.80, 0.77, hi)[1] is Verdict.REGRESSION
    assert judge(0.80, 0.85, hi)[1] is Verdict.BETTER
    lo = Tolerance(Direction.LOWER, relative=0.1)
    assert judge(2.0, 2.19, lo) == (pytest.approx(0.2), Verdict.OK)
    assert judge(2.0, 2.21, lo)[1] is Verdict.REGRESSION
    assert judge(2.0, math.nan, lo)[1] is Verdict.MISSING
    assert judge(math.nan, 1.0, lo)[1] is Verdict.UNJUDGED
    assert judge(1.0, 9.0, None)[1] is Verdict.UNJUDGED
    exact = Tolerance(Direction.LOWER)
    assert judge(0.0, 0.0, exact)[1] is Verdict.OK
    assert judge(0.0, 1.0, exact)[1] is Verdict.REGRESSION


def test_several_runs_per_side_compare_means_with_spread():
    base = [dict(BASE, precision=p) for p in (0.78, 0.80, 0.82)]
    cand = [dict(BASE, precision=p, goal_reached=g) for p, g in ((0.70, True), (0.74, False))]
    result = compare_summaries(base, cand)
    m = by_name(result)
    assert (result.n_base, result.n_candidate) == (3, 2)
    assert m["precision"].base_mean == pytest.approx(0.80)
    assert m["precision"].base_std == pytest.approx(0.02)
    assert m["precision"].candidate_mean == pytest.approx(0.72)
    assert m["precision"].delta == pytest.approx(-0.08)
    assert m["precision"].verdict is Verdict.REGRESSION
    assert m["goal_reached"].candidate_mean == 0.5 and m["goal_reached"].regressed
    assert m["wall_s"].verdict is Verdict.UNJUDGED  # shown, never judged
    assert {r.name for r in result.regressed} == {"precision", "goal_reached"}
    assert mean_std([1.0, None, 3.0]) == (2.0, pytest.approx(math.sqrt(2)))


def test_tolerances_from_toml_and_overrides(tmp_path):
    path = tmp_path / "tol.toml"
    path.write_text('[precision]\nabsolute = 0.1\n[rpe_deg]\ndirection = "lower"\n')
    tol = load_tolerances(path)
    assert tol["precision"] == Tolerance(Direction.HIGHER, absolute=0.1)
    assert tol["rpe_deg"].direction is Direction.LOWER  # a metric without a default
    assert tol["ate_m"] == DEFAULT_TOLERANCES["ate_m"]
    tol = override_tolerance(tol, "ate_m=25%")
    assert tol["ate_m"] == Tolerance(Direction.LOWER, absolute=0.0, relative=0.25)
    assert override_tolerance(tol, "recall=0.3")["recall"].absolute == 0.3
    with pytest.raises(ConfigError, match="expected NAME=VALUE"):
        override_tolerance(tol, "recall")
    path.write_text('[precision]\ndirection = "up"\n')
    with pytest.raises(ConfigError, match=r"tol.toml: field 'precision.direction'"):
        load_tolerances(path)


def test_compare_files_finds_the_summary_beside_the_output(tmp_path):
    base = write_summary(tmp_path / "base.parquet")
    cand = write_summary(tmp_path / "cand.parquet", ate_m=0.2)
    result = compare_files([base], [tables.summary_path(cand)])
    assert [m.name for m in result.regressed] == ["ate_m"]
    with pytest.raises(LogError, match="no such metrics summary"):
        compare_files([tmp_path / "none.parquet"], [cand])


def test_cli_exit_codes(tmp_path):
    base = write_summary(tmp_path / "base.parquet")
    same = write_summary(tmp_path / "same.parquet", precision=0.79)
    worse = write_summary(tmp_path / "worse.parquet", collisions=1)
    runner = CliRunner()
    ok = runner.invoke(compare_command, [str(base), str(same)])
    assert ok.exit_code == 0, ok.output
    assert "no regression" in ok.output
    bad = runner.invoke(compare_command, ["-b", str(base), "-b", str(same), "-c", str(worse)])
    assert bad.exit_code == 1
    assert "regression beyond tolerance: collisions" in bad.output
    loose = runner.invoke(compare_command, [str(base), str(worse), "-t", "collisions=1"])
    assert loose.exit_code == 0
    usage = runner.invoke(compare_command, [str(base)])
    assert usage.exit_code == 2 and "BASE CANDIDATE" in usage.output
    missing = runner.invoke(compare_command, [str(base), str(tmp_path / "x.parquet")])
    assert missing.exit_code == 2
