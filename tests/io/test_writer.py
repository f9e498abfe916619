"""LogWriter: atomic writes, what it refuses, and logs that `mcap doctor` accepts."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from flylog.errors import LogError, OutputError
from flylog.geometry import Pose2D
from flylog.io import Compression, LogConfig, LogWriter, contract, encode, open_log
from flylog.io.contract import CommandStatus

from .conftest import write_sample


def odom(t: int) -> object:
    return encode.pose_in_frame(Pose2D(0.1, 0.2, 0.3), t, "odom")


def test_log_appears_only_when_the_block_ends(tmp_path):
    path = tmp_path / "run.mcap"
    with LogWriter(path) as log:
        log.write(contract.ODOM, 1, odom(1))
        assert not path.exists()
        (tmp,) = tmp_path.iterdir()
        assert tmp.name.startswith(".run.mcap.") and tmp.name.endswith(".part")
    assert [p.name for p in tmp_path.iterdir()] == ["run.mcap"]
    assert open_log(path).topics()[contract.ODOM].count == 1
    umask = os.umask(0)
    os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask


@pytest.mark.parametrize("exc_type", [RuntimeError, KeyboardInterrupt])
def test_failed_block_leaves_nothing_and_keeps_an_existing_file(tmp_path, exc_type):
    path = tmp_path / "run.mcap"
    path.write_bytes(b"the previous log")
    with pytest.raises(exc_type), LogWriter(path) as log:
        log.write(contract.ODOM, 1, odom(1))
        raise exc_type("stop")
    assert [p.name for p in tmp_path.iterdir()] == ["run.mcap"]
    assert path.read_bytes() == b"the previous log"


def test_failed_block_without_a_previous_file_leaves_no_file(tmp_path):
    with pytest.raises(ValueError, match="boom"), LogWriter(tmp_path / "run.mcap"):
        raise ValueError("boom")
    assert list(tmp_path.iterdir()) == []


def test_successful_block_replaces_an_existing_file(tmp_path):
    path = tmp_path / "run.mcap"
    path.write_bytes(b"old")
    with LogWriter(path) as log:
        log.write(contract.ODOM, 1, odom(1))
    assert open_log(path).complete


def test_writing_is_deterministic(tmp_path):
    a = write_sample(tmp_path / "a.mcap", frames=3)
    b = write_sample(tmp_path / "b.mcap", frames=3)
    assert a.path.read_bytes() == b.path.read_bytes()


def test_refuses_times_going_back_on_a_topic_or_lagging_too_far(tmp_path):
    with LogWriter(tmp_path / "x.mcap") as log:
        log.write(contract.ODOM, 100, odom(100))
        with pytest.raises(LogError, match=r"/odom: log time 99 ns is before the previous one"):
            log.write(contract.ODOM, 99, odom(99))
        log.write(contract.TRUTH_POSE, 50, odom(50))  # other topics may lag a little
        log.write(contract.TRUTH_POSE, 3_000_000_000, odom(3_000_000_000))
        with pytest.raises(LogError, match=r"more than 1000000000 ns behind"):
            log.write(contract.ODOM, 1_000_000_000, odom(1_000_000_000))


def test_refuses_messages_of_the_wrong_schema(tmp_path):
    with LogWriter(tmp_path / "x.mcap") as log:
        wrong = r"/odom carries foxglove.PoseInFrame messages, got a foxglove.RawImage"
        with pytest.raises(LogError, match=wrong):
            log.write(contract.ODOM, 0, encode.raw_image(np.zeros((2, 2), np.uint8), 0, "c"))
        with pytest.raises(LogError, match=r"/odom carries foxglove.PoseInFrame .* not a dict"):
            log.write(contract.ODOM, 0, {"x": 1})
        with pytest.raises(LogError, match=r"carries flylog\.Command messages, got a str"):
            log.write(contract.PLANNER_COMMAND, 0, "go")
        with pytest.raises(LogError, match="not in the flylog contract"):
            log.write("/elsewhere", 0, {"x": 1})
        with pytest.raises(LogError, match="cannot be written as JSON"):
            log.write(
                contract.PLANNER_COMMAND,
                0,
                encode.command(float("nan"), 0.0, CommandStatus.STUCK, 0),
            )
        log.write("/extra/pose", 0, odom(0))  # a Foxglove message on a topic of one's own


def test_refuses_use_outside_a_block_and_bad_places(tmp_path):
    writer = LogWriter(tmp_path / "x.mcap")
    with pytest.raises(LogError, match="inside a `with` block"):
        writer.write(contract.ODOM, 0, odom(0))
    with pytest.raises(OutputError, match="does not exist"), LogWriter(tmp_path / "no" / "x.mcap"):
        pass
    with LogWriter(tmp_path / "y.mcap") as log, pytest.raises(LogError, match="strings"):
        log.add_metadata("run", {"seed": 3})  # type: ignore[dict-item]


def test_config_and_compression_names(tmp_path):
    assert LogConfig().compression is Compression.ZSTD
    with pytest.raises(ValueError, match="'gzip' is not a valid Compression"):
        LogWriter(tmp_path / "x.mcap", compression="gzip")
    config = LogConfig(compression=Compression.ZSTD, chunk_size=8192)
    with LogWriter.from_config(tmp_path / "x.mcap", config) as log:
        log.write(contract.ODOM, 0, odom(0))
    assert b"zstd" in (tmp_path / "x.mcap").read_bytes()


def pymcap_cli() -> str:
    found = Path(sys.executable).parent / "pymcap-cli"
    if found.exists():
        return str(found)
    which = shutil.which("pymcap-cli")
    if which is None:
        pytest.skip("pymcap-cli (a test dependency) is not installed")
    return which


@pytest.mark.parametrize("compression", ["zstd", "none"])
def test_mcap_doctor_finds_no_error_or_warning(tmp_path, compression):
    sample = write_sample(tmp_path / "d.mcap", frames=4, compression=compression, chunk_size=8192)
    done = subprocess.run(
        [pymcap_cli(), "doctor", "--format", "jsonl", str(sample.path)],
        capture_output=True,
        text=True,
        check=False,
    )
    lines = [json.loads(line) for line in done.stdout.splitlines() if line.strip()]
    summary = lines[-1]
    problems = [f for f in lines if f.get("severity") in ("error", "warning")]
    assert summary["type"] == "summary" and summary["messages"] == sample.count
    assert (summary["errors"], summary["warnings"], problems) == (0, 0, [])
    assert summary["complete"] is True and summary["chunks"] > 1
    assert done.returncode == 0
