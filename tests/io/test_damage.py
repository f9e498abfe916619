"""Logs damaged where a reader trusting the summary goes wrong: summaries whose records
disagree with the data (with a CRC recomputed, as a faulty writer would leave them, or
without), damaged attachments, metadata and schemas. The reader trusts the data, warns
with what was lost, and never lets a parser's exception through."""

from __future__ import annotations

import struct
import warnings
import zlib
from pathlib import Path

import pytest

from flylog.errors import LogError
from flylog.io import DamagedLogWarning, contract, open_log

from .conftest import Sample, write_sample

_RECORD = struct.Struct("<BQ")
_FOOTER = struct.Struct("<BQQQI")
MAGIC = b"\x89MCAP0\r\n"
CHUNK_INDEX, STATISTICS, SCHEMA, ATTACHMENT, METADATA = 0x08, 0x0B, 0x03, 0x09, 0x0C


def summary_of(data: bytes) -> tuple[int, list[bytes]]:
    """The summary's start and its records (header included)."""
    _, _, start, _, _ = _FOOTER.unpack_from(data, len(data) - _FOOTER.size - len(MAGIC))
    end = len(data) - _FOOTER.size - len(MAGIC)
    records, at = [], start
    while at < end:
        _, length = _RECORD.unpack_from(data, at)
        records.append(data[at : at + _RECORD.size + length])
        at += _RECORD.size + length
    return start, records


def with_summary(data: bytes, records: list[bytes], *, crc: bool = True) -> bytes:
    """``data`` with its summary replaced by ``records`` and a footer whose CRC matches
    them (or is 0: not computed)."""
    start, _ = summary_of(data)
    body = b"".join(records)
    value = zlib.crc32(struct.pack("<BQQQ", 0x02, 20, start, 0), zlib.crc32(body)) if crc else 0
    return data[:start] + body + _FOOTER.pack(0x02, 20, start, 0, value) + MAGIC


def read(path: Path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        log = open_log(path)
        times = (log.start_ns, log.end_ns)
        got = [(m.topic, m.log_time_ns) for m in log.messages()]
    damage = [str(w.message) for w in caught if issubclass(w.category, DamagedLogWarning)]
    return got, times, damage


@pytest.fixture(scope="module")
def chunked(tmp_path_factory: pytest.TempPathFactory) -> tuple[Sample, list, tuple[int, int]]:
    path = tmp_path_factory.mktemp("damage") / "full.mcap"
    sample = write_sample(path, frames=12, chunk_size=8192, compression="lz4")
    got, times, damage = read(path)
    assert not damage
    return sample, got, times


def kinds(records: list[bytes], opcode: int) -> list[int]:
    return [i for i, r in enumerate(records) if r[0] == opcode]


@pytest.mark.parametrize("crc", [True, False])
def test_a_duplicated_chunk_index_does_not_replay_its_chunk_twice(chunked, tmp_path, crc):
    sample, original, times = chunked
    data = sample.path.read_bytes()
    _, records = summary_of(data)
    i = kinds(records, CHUNK_INDEX)[2]
    bad = tmp_path / "dup.mcap"
    bad.write_bytes(with_summary(data, [*records[: i + 1], records[i], *records[i + 1 :]], crc=crc))
    got, got_times, damage = read(bad)
    assert got == original and got_times == times
    assert len(damage) == 1 and "read front to back from its data section" in damage[0]
    assert "overlapping chunks" in damage[0] or "summary CRC" in damage[0]


def test_a_wrong_statistics_end_time_does_not_change_the_log_times(chunked, tmp_path):
    sample, original, times = chunked
    data = sample.path.read_bytes()
    _, records = summary_of(data)
    (i,) = kinds(records, STATISTICS)
    stats = bytearray(records[i])
    # message count (8), schema count (2), channel, attachment, metadata, chunk counts (4
    # each), start time (8), end time (8)
    end_at = _RECORD.size + 8 + 2 + 4 * 4 + 8
    stats[end_at : end_at + 8] = struct.pack("<Q", times[1] * 2)
    bad = tmp_path / "stats.mcap"
    bad.write_bytes(with_summary(data, [*records[:i], bytes(stats), *records[i + 1 :]]))
    got, got_times, damage = read(bad)
    assert got == original and got_times == times
    assert "statistics span" in damage[0] and "its chunks hold messages from" in damage[0]


def test_a_missing_chunk_index_loses_no_message(chunked, tmp_path):
    sample, original, _ = chunked
    data = sample.path.read_bytes()
    _, records = summary_of(data)
    indexes = kinds(records, CHUNK_INDEX)
    i = indexes[3]
    bad = tmp_path / "missing.mcap"
    bad.write_bytes(with_summary(data, records[:i] + records[i + 1 :]))
    got, _, damage = read(bad)
    assert got == original
    assert f"counts {len(indexes)} chunks but indexes {len(indexes) - 1}" in damage[0]


def test_messages_on_a_channel_the_summary_lacks_are_a_warning_not_a_key_error(chunked, tmp_path):
    sample, original, _ = chunked
    data = sample.path.read_bytes()
    _, records = summary_of(data)
    channel = next(i for i, r in enumerate(records) if r[0] == 0x04)
    bad = tmp_path / "channel.mcap"
    bad.write_bytes(with_summary(data, records[:channel] + records[channel + 1 :]))
    log = open_log(bad)
    assert not log.complete
    got, _, damage = read(bad)
    assert got == original and "which it lacks" in damage[0]


def test_a_damaged_attachment_is_skipped_with_its_name(tmp_path):
    sample = write_sample(tmp_path / "att.mcap")
    data = bytearray(sample.path.read_bytes())
    at = data.index(b"[scene]\nname = 'test'")
    data[at + 3] ^= 0x20  # the writer's attachment CRC no longer matches
    bad = tmp_path / "bad-att.mcap"
    bad.write_bytes(bytes(data))
    with pytest.warns(DamagedLogWarning, match=r"skipped damaged attachment\(s\) 'scene\.toml'"):
        assert open_log(bad).attachments() == []


def test_a_damaged_scene_attachment_is_an_error_for_metrics_not_other_figures(tmp_path):
    from flylog.sources.truth import read_scene

    fixture = Path(__file__).resolve().parents[2] / "fixtures" / "logs" / "near-obstacle.mcap"
    data = bytearray(fixture.read_bytes())
    at = data.index(b"goal")
    data[at + 12] ^= 0x01
    bad = tmp_path / "scene.mcap"
    bad.write_bytes(bytes(data))
    with (
        pytest.warns(DamagedLogWarning, match="scene.toml"),
        pytest.raises(LogError, match=r"has no 'scene\.toml' attachment"),
    ):
        read_scene(open_log(bad))


def test_metadata_that_is_not_utf8_is_skipped_with_a_warning(tmp_path):
    sample = write_sample(tmp_path / "meta.mcap")
    data = bytearray(sample.path.read_bytes())
    at = data.index(b"scene", data.index(b"seed"))  # in the metadata record, not the chunk
    data[at] = 0xFF
    bad = tmp_path / "bad-meta.mcap"
    bad.write_bytes(bytes(data))
    with pytest.warns(DamagedLogWarning, match=r"skipped damaged metadata 'run'"):
        assert open_log(bad).metadata() == {}


def test_a_garbled_schema_is_a_log_error_naming_the_topic(tmp_path):
    sample = write_sample(tmp_path / "schema.mcap")
    data = sample.path.read_bytes()
    _, records = summary_of(data)
    out = []
    for r in records:
        if r[0] == SCHEMA and b"foxglove.PoseInFrame" in r:
            head = len(r) - 200  # the descriptor set's bytes end the record
            r = r[:head] + bytes(b ^ 0x5A for b in r[head:])
        out.append(r)
    bad = tmp_path / "bad-schema.mcap"
    bad.write_bytes(with_summary(data, out))
    with pytest.raises(
        LogError, match=rf"bad-schema\.mcap: cannot decode the message on {contract.ODOM}"
    ):
        list(open_log(bad).messages([contract.ODOM]))


def test_the_first_message_of_a_topic_whose_chunks_are_lost_is_a_log_error(chunked, tmp_path):
    sample, _, _ = chunked
    data = bytearray(sample.path.read_bytes())
    at = data.index(b"lz4") + 20  # inside the first chunk's compressed records
    data[at : at + 16] = bytes(16)
    bad = tmp_path / "first.mcap"
    bad.write_bytes(bytes(data))
    log = open_log(bad)
    assert log.first(contract.ODOM).topic == contract.ODOM
    with (
        pytest.warns(DamagedLogWarning),
        pytest.raises(LogError, match=r"no message on /camera/left/calibration \(the log lists 1"),
    ):
        log.first(contract.LEFT_CALIBRATION)


def test_an_attachment_whose_crc_turned_to_zeroes_is_skipped(tmp_path):
    sample = write_sample(tmp_path / "att0.mcap")
    data = bytearray(sample.path.read_bytes())
    end = data.index(b"[scene]\nname = 'test'\n") + len(b"[scene]\nname = 'test'\n")
    data[end : end + 4] = bytes(4)  # its CRC reads "not computed", its summary's does not
    bad = tmp_path / "bad-att0.mcap"
    bad.write_bytes(bytes(data))
    with pytest.warns(DamagedLogWarning, match="has no CRC, where its log's writer computes"):
        assert open_log(bad).attachments() == []
