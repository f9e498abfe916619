import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from flylog.cli.compare import compare as compare_command
from flylog.errors import ConfigError, LogError
from flylog.metrics import tables
from flylog.metrics.compare import (
    DEFAULT_TOLERANCES,
    Direction,
    MetricKind,
    Tolerance,
    Verdict,
    compare_files,
    compare_summaries,
    load_tolerances,
    mean_std,
    override_tolerance,
)

# A replay's summary (open loop: the run is not its log).
BASE = {
    "run": "run.mcap",
    "log": "log.mcap",
    "precision": 0.80,
    "ate_m": 0.10,
    "goal_reached": True,
    "collisions": 0,
    "wall_s": 9.0,
}


def write_summary(path: Path, **values) -> Path:
    """A metrics output NAME.parquet whose summary holds BASE updated with ``values``."""
    row = {c.name: None for c in tables.SUMMARY_COLUMNS}
    row.update(BASE, **values)
    tables.write_table(tables.summary_path(path), tables.SUMMARY_COLUMNS, [row], {})
    return path


def by_name(result):
    return {m.name: m for m in result.metrics}


def rows(**columns):
    """Summary rows, one per value of the columns' lists."""
    n = len(next(iter(columns.values())))
    return [dict(BASE, **{k: v[i] for k, v in columns.items()}) for i in range(n)]


def test_seed_noise_is_no_regression_and_a_real_drop_is():
    """Five seeds a side: a drop of one seed-sd is inconclusive or no change, never a
    regression; a drop far beyond the tolerance and the noise is."""
    base = rows(precision=[0.80, 0.82, 0.78, 0.81, 0.79])
    noisy = rows(precision=[0.79, 0.81, 0.77, 0.80, 0.78])
    worse = rows(precision=[0.70, 0.72, 0.69, 0.71, 0.73])
    assert by_name(compare_summaries(base, noisy))["precision"].verdict is Verdict.INCONCLUSIVE
    m = by_name(compare_summaries(base, worse))["precision"]
    assert m.verdict is Verdict.REGRESSION and m.regressed
    s = m.judgement.shift
    # every candidate is below every base value: the 5th of the 25 differences bounds it
    diffs = sorted(c["precision"] - b["precision"] for b in base for c in worse)
    assert (s.low, s.high) == (diffs[4], diffs[-5]) and s.test == "mann-whitney"
    assert m.judgement.p_regression == pytest.approx(1 / 252)
    assert m.delta == pytest.approx(0.71 - 0.80)


def test_metric_kinds_decide_what_is_judged():
    base = rows(precision=[0.8] * 3, ate_m=[0.1] * 3, wall_s=[9.0] * 3)
    cand = rows(precision=[0.8] * 3, ate_m=[0.9] * 3, wall_s=[90.0] * 3)
    got = by_name(compare_summaries(base, cand))
    assert got["ate_m"].kind is MetricKind.LOG and got["ate_m"].verdict is Verdict.UNJUDGED
    assert got["wall_s"].kind is MetricKind.WALL_CLOCK
    assert got["wall_s"].verdict is Verdict.UNJUDGED
    assert "wall-clock" in got["wall_s"].judgement.reason
    # a closed loop's run is its log: the trajectory is the run's, judged
    closed = [dict(r, log="run.mcap") for r in base], [dict(r, log="run.mcap") for r in cand]
    got = by_name(compare_summaries(*closed))
    assert got["ate_m"].kind is MetricKind.RUN and got["ate_m"].verdict is Verdict.REGRESSION
    # wall-clock judged once given a tolerance, in its own direction (lower is better)
    tol = override_tolerance(DEFAULT_TOLERANCES, "wall_s=50%")
    assert tol["wall_s"].direction is Direction.LOWER
    got = by_name(compare_summaries(base, cand, tol))
    assert got["wall_s"].verdict is Verdict.REGRESSION


def test_missing_and_empty_metrics():
    base = rows(precision=[0.8, 0.8, 0.8], recall=[0.5, 0.5, 0.5])
    cand = rows(precision=[0.8, 0.8, 0.8], recall=[None, None, None])
    got = by_name(compare_summaries(base, cand))
    assert got["recall"].verdict is Verdict.MISSING and got["recall"].regressed
    assert "f_score" not in got  # null on both sides: not shown
    assert mean_std([1.0, None, 3.0]) == (2.0, pytest.approx(math.sqrt(2)))


def test_paired_sides_use_the_signed_rank_interval():
    base = rows(precision=[0.80, 0.70, 0.90, 0.60, 0.85])
    cand = rows(precision=[0.79, 0.69, 0.895, 0.59, 0.84])  # each seed a little lower
    unpaired = by_name(compare_summaries(base, cand))["precision"]
    tol = override_tolerance(DEFAULT_TOLERANCES, "precision=0.02")
    paired = by_name(compare_summaries(base, cand, tol, paired=True))["precision"]
    assert unpaired.judgement.shift.high > 0.1  # the seeds' spread hides the shift
    assert paired.judgement.shift.test == "wilcoxon-signed-rank"
    d = np.array([c["precision"] - b["precision"] for b, c in zip(base, cand, strict=True)])
    assert (paired.judgement.shift.low, paired.judgement.shift.high) == (d.min(), d.max())
    assert paired.verdict is Verdict.NO_CHANGE  # within 0.02 with confidence
    with pytest.raises(ValueError, match="as many runs"):
        compare_summaries(base, cand[:4], paired=True)


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
    assert override_tolerance(tol, "cell_cpu_s=10%")["cell_cpu_s"].direction is Direction.LOWER
    with pytest.raises(ConfigError, match="expected NAME=VALUE"):
        override_tolerance(tol, "recall")
    path.write_text('[precision]\ndirection = "up"\n')
    with pytest.raises(ConfigError, match=r"tol.toml: field 'precision.direction'"):
        load_tolerances(path)
    assert not any(name in DEFAULT_TOLERANCES for name in ("wall_s", "evaluations_per_s"))


def test_compare_files_finds_the_summary_beside_the_output(tmp_path):
    base = [write_summary(tmp_path / f"base{i}.parquet", precision=0.8 + i / 100) for i in range(3)]
    cand = [write_summary(tmp_path / f"cand{i}.parquet", precision=0.5 + i / 100) for i in range(3)]
    result = compare_files(base, [tables.summary_path(c) for c in cand])
    assert [m.name for m in result.regressed] == ["precision"] and not result.paired
    with pytest.raises(LogError, match="no such metrics summary"):
        compare_files([tmp_path / "none.parquet"], cand)


def test_cli_exit_codes(tmp_path):
    base = [write_summary(tmp_path / f"b{i}.parquet", precision=0.8 + i / 100) for i in range(3)]
    same = [write_summary(tmp_path / f"s{i}.parquet", precision=0.8 + i / 100) for i in range(3)]
    worse = [write_summary(tmp_path / f"w{i}.parquet", precision=0.6 + i / 100) for i in range(3)]

    def args(b, c):
        return [*(a for p in b for a in ("-b", str(p))), *(a for p in c for a in ("-c", str(p)))]

    runner = CliRunner()
    ok = runner.invoke(compare_command, args(base, same))
    assert ok.exit_code == 0, ok.output
    assert "no regression" in ok.output
    bad = runner.invoke(compare_command, args(base, worse))
    assert bad.exit_code == 1
    assert "regression beyond tolerance:\n  precision" in bad.output
    loose = runner.invoke(compare_command, [*args(base, worse), "-t", "precision=0.3"])
    assert loose.exit_code == 0
    # one run a side: too few to tell, inconclusive (not a failure)
    one = runner.invoke(compare_command, [str(base[0]), str(worse[0])])
    assert one.exit_code == 0 and "inconclusive" in one.output
    strict = runner.invoke(compare_command, [*args(base, worse), "--alpha", "0.01"])
    assert strict.exit_code == 0  # 3 a side cannot reach 1 %: 1/20 > 0.01
    usage = runner.invoke(compare_command, [str(base[0])])
    assert usage.exit_code == 2 and "BASE CANDIDATE" in usage.output
    missing = runner.invoke(compare_command, [str(base[0]), str(tmp_path / "x.parquet")])
    assert missing.exit_code == 2
    alpha = runner.invoke(compare_command, [*args(base, same), "--alpha", "0.7"])
    assert alpha.exit_code == 2
