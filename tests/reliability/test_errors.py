"""Bad input is one line and exit code 2, an unexpected exception one line and exit code 1
(its traceback with FLYLOG_DEBUG=1), never a traceback otherwise."""

from __future__ import annotations

import pytest

from tests.reliability.conftest import error_lines, run

NOT_FINITE = [
    (["simulate", "s.toml", "-o", "x.mcap", "--duration", "nan"], "--duration"),
    (["simulate", "s.toml", "-o", "x.mcap", "--duration", "inf"], "--duration"),
    (["simulate", "s.toml", "-o", "x.mcap", "--frame-rate", "nan"], "--frame-rate"),
    (["replay", "log.mcap", "-o", "r.mcap", "--evals-per-second", "nan"], "--evals-per-second"),
    (["replay", "log.mcap", "-o", "r.mcap", "--snapshot-rate", "inf"], "--snapshot-rate"),
    (["replay", "log.mcap", "-o", "r.mcap", "--goal", "nan,0"], "--goal"),
    (["replay", "log.mcap", "-o", "r.mcap", "--goal", "0,-inf"], "--goal"),
    (["metrics", "log.mcap", "-o", "m.parquet", "--tau", "nan"], "--tau"),
    (["metrics", "log.mcap", "-o", "m.parquet", "--goal-tolerance", "inf"], "--goal-tolerance"),
    (["experiment", "sonar", "-o", "e", "--duration", "nan"], "--duration"),
]


@pytest.mark.parametrize(("args", "option"), NOT_FINITE)
def test_numbers_that_are_not_finite_are_refused_by_option(work, args, option):
    result = run(*args)
    assert result.exit_code == 2
    assert f"Invalid value for '{option}'" in result.stderr
    assert "finite" in result.stderr
    assert sorted(p.name for p in work.iterdir()) == ["log.mcap", "s.toml"]


def test_a_binary_file_as_a_scene_names_the_file(work):
    (work / "bin.toml").write_bytes(bytes(range(256)) * 8)
    result = run("simulate", "bin.toml", "-o", "x.mcap")
    assert result.exit_code == 2
    assert error_lines(result) == ["error: bin.toml: not a TOML file (not UTF-8 text)"]


def test_an_unreadable_config_is_a_config_error(tmp_path):
    from flylog.config import read_toml
    from flylog.errors import ConfigError

    with pytest.raises(ConfigError, match=r"cannot be read \(Is a directory\)"):
        read_toml(tmp_path)


def test_every_mistake_of_a_config_in_one_line(work):
    (work / "bad.toml").write_text(
        "evals_per_second = nan\nseed = -1\ncolour = 1\n[planner]\ntick_rate = inf\n"
    )
    result = run("replay", "log.mcap", "-o", "r.mcap", "--config", "bad.toml")
    assert result.exit_code == 2
    (line,) = error_lines(result)
    assert line.startswith("error: bad.toml: 4 problems: unknown field 'colour'")
    assert "field 'evals_per_second': expected a finite number, got nan" in line
    assert "field 'seed': must be at least 0, got -1" in line
    assert "field 'planner.tick_rate': expected a finite number, got inf" in line


def test_a_bug_is_one_line_and_exit_1_and_its_traceback_with_flylog_debug(work, monkeypatch):
    def broken(path):
        raise KeyError("oops")

    monkeypatch.setattr("flylog.scene.load.load_scene", broken)
    result = run("simulate", "s.toml", "-o", "x.mcap")
    assert result.exit_code == 1
    (line,) = error_lines(result)
    assert line.startswith("internal error (a bug in flylog, please report it): KeyError")
    assert line.endswith("FLYLOG_DEBUG=1 shows the traceback")
    debug = run("simulate", "s.toml", "-o", "x.mcap", env={"FLYLOG_DEBUG": "1"})
    assert isinstance(debug.exception, KeyError)  # raised on: Python prints the traceback


def test_flylog_debug_adds_the_traceback_of_a_user_error(work):
    (work / "bad.toml").write_text("seed = -1\n")
    result = run(
        "replay", "log.mcap", "-o", "r.mcap", "--config", "bad.toml", env={"FLYLOG_DEBUG": "1"}
    )
    assert result.exit_code == 2
    assert "Traceback" in result.stderr
    assert result.stderr.rstrip().splitlines()[-1].startswith("error: bad.toml:")


@pytest.mark.parametrize(
    ("tolerance", "message"),
    [
        ("precison=0.1", "unknown metric 'precison'; valid metrics: snapshots, duration_s, "),
        ("precision=inf", "with a finite VALUE"),
        ("precision=nan%", "with a finite VALUE"),
    ],
)
def test_compare_refuses_an_unknown_or_infinite_tolerance(work, tolerance, message):
    result = run("compare", "-t", tolerance, "a.parquet", "b.parquet")
    assert result.exit_code == 2
    (line,) = error_lines(result)
    assert message in line and line.endswith("(option --tolerance)")


def test_compare_lists_every_mistake_of_a_tolerance_file(work):
    (work / "tol.toml").write_text("[precison]\nabsolute = 0.1\n[recall]\nabsolute = nan\n")
    result = run("compare", "--tolerances", "tol.toml", "a.parquet", "b.parquet")
    assert result.exit_code == 2
    (line,) = error_lines(result)
    assert "tol.toml: 2 problems: unknown metric 'precison'; " in line
    assert "field 'recall.absolute': expected a finite number, got nan" in line
    assert "valid metrics: snapshots" in line
