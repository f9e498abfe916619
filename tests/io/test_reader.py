"""open_log: what a log holds, errors that name the problem, damaged logs, stereo pairing."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest

from flylog.errors import LogError
from flylog.io import (
    DamagedLogWarning,
    LogMessage,
    TruncatedLogWarning,
    UnpairedImagesWarning,
    contract,
    open_log,
    pair_stereo,
    require_topics,
)

from .conftest import Sample, write_sample


def test_topics_times_attachments_metadata(sample_log: Sample):
    log = open_log(sample_log.path)
    assert log.complete
    topics = log.topics()
    assert {t: i.count for t, i in topics.items()} == {
        t: len(v) for t, v in sample_log.written.items()
    }
    assert topics[contract.SONAR].schema == "flylog.SonarRanges"
    times = [t for v in sample_log.written.values() for t, _ in v]
    assert (log.start_ns, log.end_ns) == (min(times), max(times))
    (att,) = log.attachments()
    assert (att.name, att.media_type, att.data) == (
        "scene.toml",
        "application/toml",
        b"[scene]\nname = 'test'\n",
    )
    assert log.metadata() == {"run": {"seed": "7", "scene": "test"}}


def test_topic_filter(sample_log: Sample):
    got = list(open_log(sample_log.path).messages([contract.ODOM, contract.SONAR]))
    assert {m.topic for m in got} == {contract.ODOM, contract.SONAR}
    assert len(got) == len(sample_log.written[contract.ODOM]) + len(
        sample_log.written[contract.SONAR]
    )


def test_missing_file_directory_and_not_mcap(tmp_path):
    with pytest.raises(LogError, match=r"nope\.mcap: no such file"):
        open_log(tmp_path / "nope.mcap")
    with pytest.raises(LogError, match="is a directory"):
        open_log(tmp_path)
    text = tmp_path / "notes.mcap"
    text.write_text("hello, I am not a log\n")
    with pytest.raises(LogError, match=r"notes\.mcap is not an MCAP file"):
        open_log(text)
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    with pytest.raises(LogError, match=r"empty\.mcap is not an MCAP file"):
        open_log(empty)


def test_require_topics_names_missing_and_present(sample_log: Sample):
    log = open_log(sample_log.path)
    require_topics(log, [contract.ODOM, contract.LEFT_IMAGE])
    with pytest.raises(LogError) as info:
        require_topics(log, [contract.ODOM, "/lidar", "/imu"])
    text = str(info.value)
    assert "lacks topic(s) /lidar, /imu" in text
    assert "/odom (foxglove.PoseInFrame)" in text and "/sonar (flylog.SonarRanges)" in text


def test_require_topics_names_topic_expected_and_found_schema(sample_log: Sample):
    log = open_log(sample_log.path)
    with pytest.raises(LogError, match=r"/odom should carry foxglove\.Odometry but carries "):
        require_topics(log, {contract.ODOM: "foxglove.Odometry"})


def read_all(path: Path) -> tuple[list[LogMessage], list[warnings.WarningMessage]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = list(open_log(path).messages())
    return got, list(caught)


def same_values(a: LogMessage, b: LogMessage) -> bool:
    if isinstance(a.value, np.ndarray):
        return np.array_equal(a.value, b.value, equal_nan=a.value.dtype.kind == "f")
    if isinstance(a.value, tuple) and hasattr(a.value, "xyz"):
        return np.array_equal(a.value.xyz, b.value.xyz)
    if hasattr(a.value, "ranges"):
        return np.array_equal(a.value.ranges, b.value.ranges, equal_nan=True)
    if isinstance(a.value, tuple) and hasattr(a.value, "values"):
        return np.array_equal(a.value.values, b.value.values)
    if isinstance(a.value, tuple) and hasattr(a.value, "uv"):
        return np.array_equal(a.value.uv, b.value.uv)
    if hasattr(a.value, "K"):
        return np.array_equal(a.value.P, b.value.P)
    return bool(np.all(a.value == b.value))


@pytest.fixture(scope="module")
def chunked(tmp_path_factory: pytest.TempPathFactory) -> tuple[Sample, list[LogMessage]]:
    path = tmp_path_factory.mktemp("cut") / "full.mcap"
    sample = write_sample(path, frames=12, chunk_size=8192)
    return sample, list(open_log(path).messages())


def test_log_without_its_summary_reads_the_same_as_with_it(chunked, tmp_path):
    sample, full = chunked
    data = sample.path.read_bytes()
    # the footer (opcode 0x02, 20-byte body) + magic end the file; summary_start is its field
    summary_start = int.from_bytes(data[-28:-20], "little")
    cut = tmp_path / "nosummary.mcap"
    cut.write_bytes(data[:summary_start])
    got, caught = read_all(cut)
    assert not open_log(cut).complete
    assert [(m.topic, m.log_time_ns) for m in got] == [(m.topic, m.log_time_ns) for m in full]
    assert all(same_values(a, b) for a, b in zip(got, full, strict=True))
    assert len(caught) == 1 and caught[0].category is TruncatedLogWarning
    assert f"recovered {len(full)} intact messages" in str(caught[0].message)
    assert open_log(cut).topics() == open_log(sample.path).topics()
    assert open_log(cut).metadata() == open_log(sample.path).metadata()
    assert [a.name for a in open_log(cut).attachments()] == ["scene.toml"]


@pytest.mark.parametrize("fraction", [0.02, 0.13, 0.29, 0.5, 0.61, 0.77, 0.9, 0.999])
def test_cut_log_yields_every_intact_message_then_warns(chunked, tmp_path, fraction):
    sample, full = chunked
    data = sample.path.read_bytes()
    cut_at = int(len(data) * fraction)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[:cut_at])
    got, caught = read_all(cut)
    assert [w.category for w in caught] == [TruncatedLogWarning]
    text = str(caught[0].message)
    assert str(cut) in text and f"recovered {len(got)} intact messages" in text
    # what is recovered is, topic by topic, a prefix of the full log, value for value
    for topic in {m.topic for m in full}:
        ours = [m for m in got if m.topic == topic]
        theirs = [m for m in full if m.topic == topic][: len(ours)]
        assert [m.log_time_ns for m in ours] == [m.log_time_ns for m in theirs]
        assert all(same_values(a, b) for a, b in zip(ours, theirs, strict=True))
    times = [m.log_time_ns for m in got]
    assert times == sorted(times)
    if fraction > 0.5:
        assert len(got) > len(full) // 3  # chunks of 8 KiB: most of the log survives


def test_recovered_count_grows_with_the_cut(chunked, tmp_path):
    sample, _ = chunked
    data = sample.path.read_bytes()
    counts = []
    for cut_at in range(0, len(data), len(data) // 9):
        cut = tmp_path / f"cut{cut_at}.mcap"
        cut.write_bytes(data[:cut_at])
        if cut_at < 8:
            with pytest.raises(LogError, match="is not an MCAP file"):
                open_log(cut)
            continue
        counts.append(len(read_all(cut)[0]))
    assert counts == sorted(counts) and counts[-1] > counts[0]


def zeroed_middle_chunk(sample: Sample) -> tuple[bytearray, int]:
    """The log's bytes with 64 zeroes inside a chunk in the middle, and its summary start."""
    data = bytearray(sample.path.read_bytes())
    summary_start = int.from_bytes(data[-28:-20], "little")
    middle = summary_start // 2
    data[middle : middle + 64] = bytes(64)
    return data, summary_start


def is_subsequence(part: list[LogMessage], whole: list[LogMessage]) -> bool:
    rest = iter(whole)
    return all(
        any(m.log_time_ns == w.log_time_ns and m.topic == w.topic for w in rest) for m in part
    )


def test_corrupt_chunk_of_an_unfinished_log_is_skipped(chunked, tmp_path):
    sample, full = chunked
    data, summary_start = zeroed_middle_chunk(sample)
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data[:summary_start]))  # no summary: read front to back
    got, caught = read_all(bad)
    assert 0 < len(got) < len(full) and is_subsequence(got, full)
    assert got[-1].log_time_ns == full[-1].log_time_ns  # the chunks after it are read
    skipped = [w for w in caught if w.category is DamagedLogWarning]
    assert len(skipped) == 1
    assert f"{len(full) - len(got)} messages lost, {len(got)} read" in str(skipped[0].message)
    # zeroed bytes fail the chunk's CRC, or its decompression first where they hit the frame
    assert any(
        why in str(skipped[0].message) for why in ("chunk CRC mismatch", "decompression error")
    )


def test_corrupt_chunk_of_a_finished_log_is_skipped_and_counted(chunked, tmp_path):
    sample, full = chunked
    data, _ = zeroed_middle_chunk(sample)
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    got, caught = read_all(bad)
    assert 0 < len(got) < len(full) and is_subsequence(got, full)
    assert got[-1].log_time_ns == full[-1].log_time_ns
    (warning,) = caught
    assert warning.category is DamagedLogWarning
    text = str(warning.message)
    assert "bad.mcap: skipped the chunk at byte" in text
    assert f"read {len(got)} of the {len(full)} messages" in text
    assert f"({len(full) - len(got)} lost)" in text


def test_a_cut_inside_the_only_chunk_says_the_log_is_truncated(sample_log: Sample, tmp_path):
    data = sample_log.path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])  # sample_log has one chunk
    log = open_log(cut)
    with pytest.raises(LogError, match=r"cut\.mcap is truncated or damaged \(file is cut inside"):
        require_topics(log, [contract.ODOM])


KILLED_WRITER = textwrap.dedent(
    """
    import os, signal, sys
    sys.path.insert(0, {root!r})
    from flylog.geometry import Pose2D
    from flylog.io import LogWriter, contract, encode
    with LogWriter({path!r}, chunk_size=4096) as log:
        for k in range(200):
            t = k * 10_000_000
            log.write(contract.ODOM, t, encode.pose_in_frame(Pose2D(k, 0, 0), t, "odom"))
        os.kill(os.getpid(), signal.SIGKILL)
    """
)


def test_log_of_a_killed_writer_is_read_up_to_its_last_chunk(tmp_path):
    target = tmp_path / "killed.mcap"
    root = str(Path(__file__).resolve().parents[2])
    done = subprocess.run(
        [sys.executable, "-c", KILLED_WRITER.format(root=root, path=str(target))], check=False
    )
    assert done.returncode == -signal.SIGKILL
    assert not target.exists()
    (part,) = tmp_path.glob(".killed.mcap.*.part")
    got, caught = read_all(part)
    assert 100 < len(got) < 200  # the chunk being built when it died is lost
    assert [m.value.pose.x for m in got] == list(range(len(got)))
    assert [w.category for w in caught] == [TruncatedLogWarning]
    assert f"recovered {len(got)} intact messages" in str(caught[0].message)


def test_stereo_pairs_from_a_log(sample_log: Sample):
    pairs = list(open_log(sample_log.path).stereo_pairs())
    lefts = sample_log.written[contract.LEFT_IMAGE]
    rights = sample_log.written[contract.RIGHT_IMAGE]
    assert [p.stamp_ns for p in pairs] == [t for t, _ in lefts]
    for pair, (_, left), (_, right) in zip(pairs, lefts, rights, strict=True):
        np.testing.assert_array_equal(pair.left, left)
        np.testing.assert_array_equal(pair.right, right)


def image_message(side: str, t: int) -> LogMessage:
    topic = contract.IMAGE_TOPICS[side]
    return LogMessage(topic, t, contract.RAW_IMAGE, np.full((2, 2), t % 256, dtype=np.uint8))


def test_pairing_passes_other_messages_and_skips_orphans():
    ms = 1_000_000
    stream = [
        image_message("left", 0),
        LogMessage(contract.ODOM, 1 * ms, contract.POSE_IN_FRAME, "odom"),
        image_message("right", 2 * ms),  # within 5 ms of the left: a pair
        image_message("left", 66 * ms),  # its right is missing
        image_message("left", 133 * ms),
        image_message("right", 133 * ms),
        image_message("right", 200 * ms),  # its left is missing, and nothing follows
    ]
    with pytest.warns(UnpairedImagesWarning, match="2 images had no partner within 5000000 ns"):
        out = list(pair_stereo(stream))
    assert [(m.topic, m.log_time_ns) for m in out] == [
        (contract.ODOM, 1 * ms),
        (contract.STEREO_PAIRS, 0),
        (contract.STEREO_PAIRS, 133 * ms),
    ]
    assert out[1].value.right[0, 0] == (2 * ms) % 256


def test_pairing_buffers_at_most_max_pending_images():
    ms = 1_000_000
    lefts = [image_message("left", k * 66 * ms) for k in range(5)]
    late_right = image_message("right", 0)  # the partner of the first left, 4 frames late
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnpairedImagesWarning)
        kept = list(pair_stereo([*lefts, late_right], max_pending=8))
        bounded = list(pair_stereo([*lefts, late_right], max_pending=3))
    assert [m.log_time_ns for m in kept] == [0]
    assert bounded == []  # the first left had been dropped to keep 3 waiting


def test_a_finished_log_parses_its_summary_once(sample_log: Sample, monkeypatch):
    """Metadata, attachments and messages reuse the summary read and checked at open."""
    from flylog.io import summary

    calls = []
    parse = summary._parsed

    def counted(*args, **kwargs):
        calls.append(1)
        return parse(*args, **kwargs)

    monkeypatch.setattr(summary, "_parsed", counted)
    log = open_log(sample_log.path)
    assert len(calls) == 1
    first = log.metadata()
    assert log.metadata() == first and first  # the records, read once and kept
    assert len(log.attachments()) == 1
    assert sum(1 for _ in log.messages([contract.ODOM])) == len(sample_log.written[contract.ODOM])
    assert len(calls) == 1


def test_reading_imports_neither_the_writer_nor_the_encoders_nor_foxglove():
    code = (
        "import sys\nfrom flylog.io import open_log, contract\n"
        "print(','.join(m for m in ('flylog.io.writer', 'flylog.io.encode', 'mcap.writer', "
        "'foxglove') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
    from flylog import io

    assert sorted(io.__all__) == sorted(io._WHERE)
    for name in io.__all__:  # every lazily imported name is there, from its own module
        assert getattr(io, name).__module__.startswith("flylog.io.")
