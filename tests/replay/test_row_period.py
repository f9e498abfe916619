"""replay's --row-period: the cameras' row period for any input (a log with or without its
flylog.shutter record, an imported dataset's log, a ROS 2 bag), the bad values it refuses
(exit 2, nothing written), and replays it gives bit for bit the same as the record does."""

import math
import re
import warnings

import pytest
from click.testing import CliRunner

from flylog.cli.main import cli
from flylog.datasets.run import import_dataset
from flylog.errors import ConfigError, LogError
from flylog.io import contract
from flylog.io.reader import open_log
from flylog.io.shutter import shutter_metadata
from flylog.replay.run import replay
from flylog.ros2.export import export_ros2
from flylog.ros2.messages import ImageFormat
from flylog.sources.door import input_at
from flylog.sources.inputs import DatasetLogWarning, ShutterOverrideWarning
from tests.datasets.layouts import write_middlebury_scene
from tests.logcopy import copy_log
from tests.replay.test_replay import LOGS, content, table_rows
from tests.ros2.bags import BagSpec, make_bag
from tests.ros2.test_equivalence import NO_SONAR, outputs

TURN = LOGS / "turn.mcap"  # 160x120 at 15 Hz, turning: a row period moves the flies
FAST = ["--flies", "200", "--generations-per-frame", "1"]


def replay_cli(log, out, *extra):
    return CliRunner().invoke(cli, ["replay", str(log), "-o", str(out), *FAST, *extra])


def with_record(tmp_path, row_period_ns, name="turn-rs.mcap"):
    """A copy of turn.mcap that carries a flylog.shutter record of ``row_period_ns``."""
    return copy_log(
        TURN,
        tmp_path / name,
        metadata=lambda records: {
            **records,
            contract.SHUTTER_METADATA: shutter_metadata(row_period_ns),
        },
    )


def run_files(tmp_path):
    return sorted(p.name for p in tmp_path.iterdir() if p.name.startswith("run"))


def test_the_option_sets_a_logs_row_period_without_the_record_and_without_a_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        source = input_at(TURN).replay_source(goal=None, row_period_us=130.0)
    assert source.inputs.row_period_ns == 130000.0
    assert input_at(TURN).replay_source(goal=None).inputs.row_period_ns == 0.0


def test_the_option_sets_a_bags_row_period_and_the_run_records_it(tmp_path):
    bag = make_bag(tmp_path / "bag", BagSpec(frames=6))
    source = input_at(bag).replay_source(goal=(1.0, 0.0), row_period_us=18.9)
    assert source.inputs.row_period_ns == 18900.0
    out = tmp_path / "run.mcap"
    result = replay_cli(bag, out, "--row-period", "18.9")
    assert result.exit_code == 0, result.output
    assert "rolling shutter of 18.9 us a row" in " ".join(result.output.split())
    meta = open_log(out).metadata()[contract.REPLAY_METADATA]
    assert meta["row_period_ns"] == "18900.0"
    plain = tmp_path / "plain.mcap"
    result = replay_cli(bag, plain)
    assert result.exit_code == 0, result.output
    assert "rolling shutter" not in result.output
    assert open_log(plain).metadata()[contract.REPLAY_METADATA]["row_period_ns"] == "0.0"


@pytest.mark.filterwarnings("ignore::flylog.sources.inputs.NoSonarWarning")
def test_the_option_sets_an_imported_datasets_row_period(tmp_path):
    write_middlebury_scene(tmp_path / "plane")
    (log,) = import_dataset("middlebury", tmp_path / "plane", tmp_path / "plane.mcap")
    with pytest.warns(DatasetLogWarning):
        plain = input_at(log.path).replay_source(goal=None)
    assert plain.inputs.row_period_ns == 0.0
    with pytest.warns(DatasetLogWarning):
        given = input_at(log.path).replay_source(goal=None, row_period_us=18.9)
    assert given.inputs.row_period_ns == 18900.0


def test_a_record_that_says_another_row_period_warns_once_and_the_option_wins(tmp_path):
    log = with_record(tmp_path, 200000.0)
    assert input_at(log).replay_source(goal=None).inputs.row_period_ns == 200000.0
    with pytest.warns(ShutterOverrideWarning) as caught:
        source = input_at(log).replay_source(goal=None, row_period_us=130.0)
    assert source.inputs.row_period_ns == 130000.0
    (warning,) = [w for w in caught if w.category is ShutterOverrideWarning]
    said = str(warning.message)
    assert str(log) in said and "200 us" in said and "130 us" in said
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the same value: nothing to warn of
        same = input_at(log).replay_source(goal=None, row_period_us=200.0)
    assert same.inputs.row_period_ns == 200000.0
    result = replay_cli(log, tmp_path / "run.mcap", "--row-period", "0")
    assert result.exit_code == 0, result.output
    text = " ".join(result.output.split())
    assert text.count("warning:") == 1 and "200 us" in text and "replaying with the 0 us" in text
    assert "rolling shutter" not in text


def test_the_option_replaces_a_malformed_record_with_a_warning(tmp_path):
    log = copy_log(
        TURN,
        tmp_path / "bad-record.mcap",
        metadata=lambda records: {
            **records,
            contract.SHUTTER_METADATA: {"version": "1", "row_period_ns": "-5"},
        },
    )
    with pytest.raises(LogError, match=re.escape("flylog.shutter.row_period_ns")):
        input_at(log).replay_source(goal=None)
    with pytest.warns(ShutterOverrideWarning, match=r"'-5' ns \(not a row period\)"):
        source = input_at(log).replay_source(goal=None, row_period_us=18.9)
    assert source.inputs.row_period_ns == 18900.0


@pytest.mark.parametrize("value", ["-1", "nan", "inf", "-inf"])
def test_a_negative_or_non_finite_row_period_exits_2_naming_the_option(tmp_path, value):
    result = replay_cli(TURN, tmp_path / "run.mcap", "--row-period", value)
    assert result.exit_code == 2, result.output
    assert "'--row-period'" in result.output
    assert ("range x>=0" if value == "-1" else "not a finite number") in result.output
    assert run_files(tmp_path) == []


@pytest.mark.parametrize("value", [-1.0, math.nan, math.inf])
def test_the_library_refuses_the_same_values_naming_the_parameter(value):
    with pytest.raises(ConfigError, match="finite number of microseconds >= 0") as raised:
        input_at(TURN).replay_source(goal=None, row_period_us=value)
    assert raised.value.parameter == "row_period_us"


def test_a_readout_longer_than_the_frame_period_exits_2_with_the_figures_and_fix(tmp_path):
    # 120 rows at 15 Hz: at most 555.556 us a row
    result = replay_cli(TURN, tmp_path / "run.mcap", "--row-period", "600")
    assert result.exit_code == 2, result.output
    text = " ".join(result.output.split())
    assert str(TURN) in text
    assert "120 rows of 600 us take 72 ms to read out" in text
    assert "frame period (66.6667 ms at 15 Hz)" in text
    assert "lower it to at most 555.556 us (option --row-period)" in text
    assert run_files(tmp_path) == []
    # a bag: 48 rows at 10 Hz, at most 2083.33 us a row
    bag = make_bag(tmp_path / "bag", BagSpec(frames=4))
    result = replay_cli(bag, tmp_path / "run.mcap", "--row-period", "2100", "--goal", "1,0")
    assert result.exit_code == 2, result.output
    text = " ".join(result.output.split())
    assert str(bag) in text and "48 rows of 2100 us" in text and "2083.33 us" in text
    assert run_files(tmp_path) == []


def test_a_global_shutter_log_with_row_period_0_replays_bit_for_bit_as_without(tmp_path):
    plain, zero = tmp_path / "plain.mcap", tmp_path / "zero.mcap"
    assert replay_cli(TURN, plain).exit_code == 0
    assert replay_cli(TURN, zero, "--row-period", "0").exit_code == 0
    assert content(zero) == content(plain)
    assert table_rows(zero.with_suffix(".parquet")) == table_rows(plain.with_suffix(".parquet"))


def test_the_option_on_a_log_without_the_record_replays_as_the_record_does(tmp_path):
    recorded_log = with_record(tmp_path, 130000.0)
    given, recorded, plain = (tmp_path / f"{n}.mcap" for n in ("given", "recorded", "plain"))
    assert replay_cli(TURN, given, "--row-period", "130").exit_code == 0
    assert replay_cli(recorded_log, recorded).exit_code == 0
    assert replay_cli(TURN, plain).exit_code == 0
    assert content(given) == content(recorded)
    assert table_rows(given.with_suffix(".parquet")) == table_rows(recorded.with_suffix(".parquet"))
    assert content(given) != content(plain)  # the row period is in effect: the flies move
    for run in (given, recorded):
        assert open_log(run).metadata()[contract.REPLAY_METADATA]["row_period_ns"] == "130000.0"


def test_a_rolling_shutter_logs_export_replays_bit_for_bit_given_its_row_period(tmp_path):
    # a bag has no place for the row period: the export of a log whose record gives 130 us
    # replays as the log does once --row-period gives it back (sonar fusion off: Range
    # carries float32 ranges, tests/ros2/test_equivalence.py)
    log = with_record(tmp_path, 130000.0)
    bag = export_ros2(log, tmp_path / "bag", image_format=ImageFormat.RGB8).output
    reference = replay(log, tmp_path / "log-run.mcap", NO_SONAR)
    given = replay(bag, tmp_path / "given.mcap", NO_SONAR, row_period_us=130.0)
    assert outputs(given.output) == outputs(reference.output)
    assert table_rows(given.table) == table_rows(reference.table)
    unsaid = replay(bag, tmp_path / "unsaid.mcap", NO_SONAR)
    assert unsaid.row_period_ns == 0.0
    assert outputs(unsaid.output) != outputs(reference.output)
