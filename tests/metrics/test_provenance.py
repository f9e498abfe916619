"""Runs tied to their logs: metrics refuses a run scored against another log than the one
it was replayed from; compare warns when its sides come from different logs or
configurations."""

from __future__ import annotations

import json
import shutil
import warnings

import pytest

from flylog.cli.main import cli
from flylog.config import to_mapping
from flylog.errors import LogError
from flylog.io.fingerprint import log_fingerprint
from flylog.metrics import tables
from flylog.metrics.compare import compare_files
from flylog.metrics.config import MetricsConfig
from flylog.metrics.provenance import ProvenanceWarning, config_digest
from flylog.metrics.score import score_run

from .helpers import FIXTURES, RULE, write_run

OTHER_LOG = FIXTURES.parent / "logs" / "near-obstacle.mcap"


def replay_meta(log, **extra) -> dict[str, str]:
    return {
        "config": json.dumps({"engine": {"flies": 100}, "obstacles": RULE}),
        "log": str(log),
        "log_fingerprint": log_fingerprint(log),
        **extra,
    }


@pytest.mark.filterwarnings("ignore:.*has no /flies topic")
def test_a_run_is_scored_against_its_own_log_and_records_where_it_came_from(sensor_log, tmp_path):
    run = write_run(tmp_path / "run.mcap", [], metadata=replay_meta(sensor_log))
    copy = tmp_path / "copy.mcap"
    shutil.copyfile(sensor_log, copy)  # the same content under another name is the same log
    summary = score_run(run, copy).summary
    assert summary["log_fingerprint"] == log_fingerprint(sensor_log)
    assert summary["run_config"] == config_digest({"engine": {"flies": 100}, "obstacles": RULE})
    assert summary["metrics_config"] == config_digest(to_mapping(MetricsConfig()))


def test_metrics_refuses_another_log_naming_both_files(sensor_log, tmp_path):
    run = write_run(tmp_path / "run.mcap", [], metadata=replay_meta(sensor_log))
    with pytest.raises(LogError) as info:
        score_run(run, OTHER_LOG)
    text = str(info.value)
    assert f"{run} was replayed from {sensor_log}" in text
    assert f"not from {OTHER_LOG}" in text and "score it against the log it was made from" in text
    assert info.value.parameter == "log"  # the CLI names its --log


def test_the_metrics_command_exits_2_on_another_log(sensor_log, tmp_path, capsys):
    run = write_run(tmp_path / "run.mcap", [], metadata=replay_meta(sensor_log))
    out = tmp_path / "m.parquet"
    argv = ["metrics", str(run), "--log", str(OTHER_LOG), "-o", str(out)]
    with pytest.raises(SystemExit) as info:
        cli.main(argv)
    assert info.value.code == 2
    assert "was replayed from" in capsys.readouterr().err
    assert not out.exists()


def test_fingerprints_tell_logs_apart_and_copies_alike(sensor_log, tmp_path):
    copy = tmp_path / "copy.mcap"
    shutil.copyfile(sensor_log, copy)
    assert log_fingerprint(copy) == log_fingerprint(sensor_log)
    assert log_fingerprint(sensor_log).startswith("summary:")
    assert log_fingerprint(OTHER_LOG) != log_fingerprint(sensor_log)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(sensor_log.read_bytes()[:-100])  # no summary: the file's own hash
    assert log_fingerprint(cut).startswith("file:")


def summary_file(path, **values):
    row = {c.name: None for c in tables.SUMMARY_COLUMNS}
    row.update(precision=0.8, run="run.mcap", log="log.mcap", **values)
    tables.write_table(tables.summary_path(path), tables.SUMMARY_COLUMNS, [row], {})
    return path


def test_compare_warns_when_its_sides_come_from_different_logs(tmp_path):
    base = summary_file(tmp_path / "b.parquet", log_fingerprint="summary:aa", run_config="c1")
    same = summary_file(tmp_path / "s.parquet", log_fingerprint="summary:aa", run_config="c1")
    other = summary_file(tmp_path / "o.parquet", log_fingerprint="summary:bb", run_config="c2")
    with pytest.warns(ProvenanceWarning) as caught:
        result = compare_files([base], [other])
    texts = [str(w.message) for w in caught]
    assert any("against different sensor logs" in t and "summary:aa" in t for t in texts)
    assert any("different replay configurations" in t for t in texts)
    assert "log_fingerprint" not in {m.name for m in result.metrics}
    with warnings.catch_warnings():
        warnings.simplefilter("error", ProvenanceWarning)
        compare_files([base], [same])


def test_a_bag_directory_is_fingerprinted_from_the_files_it_holds(tmp_path):
    bag = tmp_path / "bag"
    bag.mkdir()
    shutil.copy(FIXTURES.parent / "logs" / "turn.mcap", bag / "bag.mcap")
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    first = log_fingerprint(bag)
    assert first.startswith("dir:") and log_fingerprint(bag) == first
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {version: 9}\n")
    changed = log_fingerprint(bag)
    assert changed != first
    shutil.copy(OTHER_LOG, bag / "bag.mcap")
    assert log_fingerprint(bag) not in (first, changed)
