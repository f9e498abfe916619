"""The flylog.shutter metadata record: a log's row period, written and read; every other
input reads as a global shutter."""

import re
from pathlib import Path

import pytest

from flylog.errors import LogError
from flylog.io import contract
from flylog.io.reader import open_log
from flylog.io.shutter import readout_excess, row_period_ns, shutter_metadata
from flylog.io.writer import LogWriter
from flylog.sources.door import input_at
from tests.ros2.bags import make_bag

LOGS = Path(__file__).resolve().parents[2] / "fixtures" / "logs"


def test_the_record_reads_back_its_row_period(tmp_path):
    path = tmp_path / "rs.mcap"
    with LogWriter(path) as log:
        log.add_metadata(contract.SHUTTER_METADATA, shutter_metadata(18900.0))
    record = open_log(path).metadata()[contract.SHUTTER_METADATA]
    assert record == {"version": "1", "row_period_ns": "18900.0"}
    assert row_period_ns(open_log(path).metadata(), where="rs") == 18900.0


def test_logs_without_the_record_and_bags_read_as_a_global_shutter(tmp_path):
    log = input_at(LOGS / "near-obstacle.mcap").replay_source(goal=None)
    assert log.inputs.row_period_ns == 0.0
    bag = input_at(make_bag(tmp_path / "bag")).replay_source(goal=(1.0, 0.0))
    assert bag.inputs.row_period_ns == 0.0


@pytest.mark.parametrize("value", ["-1.0", "nan", "fast", "inf"])
def test_a_malformed_row_period_names_the_record(tmp_path, value):
    path = tmp_path / "bad.mcap"
    with LogWriter(path) as log:
        log.add_metadata(contract.SHUTTER_METADATA, {"version": "1", "row_period_ns": value})
    with pytest.raises(LogError, match=re.escape("flylog.shutter.row_period_ns")):
        row_period_ns(open_log(path).metadata(), where=str(path))


def test_a_readout_fits_a_frame_period_up_to_its_bound():
    # 120 rows at 15 Hz: 66.667 ms, 555.556 us a row
    assert readout_excess(555.5, 120, 15.0) is None
    assert readout_excess(0.0, 120, 15.0) is None
    assert readout_excess(600.0, 120, 15.0) == (
        "120 rows of 600 us take 72 ms to read out, longer than the frame period "
        "(66.6667 ms at 15 Hz); lower it to at most 555.556 us"
    )
