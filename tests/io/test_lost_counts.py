"""A chunk deleted from a finished log is counted, message by message, against what its
summary promises; metadata records carry a checksum that the reader checks."""

from __future__ import annotations

import struct
import warnings
from pathlib import Path

import pytest

from flylog.io import DamagedLogWarning, LogWriter, contract, open_log
from flylog.io.scan import messages_lost

from .conftest import write_sample
from .mutate import record_spans

CHUNK, MESSAGE_INDEX, METADATA = 0x06, 0x07, 0x0C


def _read(path: Path) -> tuple[int, list[DamagedLogWarning]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        count = sum(1 for _ in open_log(path).messages())
    return count, [w.message for w in caught if isinstance(w.message, DamagedLogWarning)]


@pytest.fixture(scope="module")
def five_chunks(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("chunks")
    # big chunks and messages, as a simulated log's: the summary lies far from the file's end
    sample = write_sample(d / "five.mcap", frames=10, chunk_size=30_000, compression="none")
    return sample.path


@pytest.mark.parametrize("which", ["second", "last"])
@pytest.mark.parametrize("indexes", [False, True], ids=["chunk", "chunk+message indexes"])
def test_a_deleted_chunk_is_counted_as_lost(five_chunks, tmp_path, which, indexes):
    data = five_chunks.read_bytes()
    spans = record_spans(data)
    chunks = [k for k, (a, _) in enumerate(spans) if data[a] == CHUNK]
    assert len(chunks) >= 5
    k = chunks[1] if which == "second" else chunks[-1]
    start, end = spans[k]
    while indexes and k + 1 < len(spans) and data[spans[k + 1][0]] == MESSAGE_INDEX:
        k += 1
        end = spans[k][1]
    mutant = tmp_path / "mutant.mcap"
    mutant.write_bytes(data[:start] + data[end:])
    whole, none = _read(five_chunks)
    assert none == []
    count, damage = _read(mutant)
    assert 0 < count < whole
    lost, exact = messages_lost(damage)
    assert (lost, exact) == (whole - count, True)
    assert any(f"({whole - count} lost)" in str(w) for w in damage)


def test_a_changed_metadata_value_is_caught_by_its_checksum(tmp_path):
    path = write_sample(tmp_path / "log.mcap").path
    assert open_log(path).metadata()["run"] == {"seed": "7", "scene": "test"}  # key hidden
    data = bytearray(path.read_bytes())
    at = data.index(b'"7"') if b'"7"' in data else data.index(b"seed") + 8
    data[at] ^= 0x01  # a bit of the value "7"
    path.write_bytes(bytes(data))
    with pytest.warns(DamagedLogWarning, match="'run' .its checksum does not match"):
        assert "run" not in open_log(path).metadata()


def test_a_record_without_its_checksum_in_a_checked_log_is_damage(tmp_path):
    path = write_sample(tmp_path / "log.mcap").path
    data = path.read_bytes()
    key = contract.METADATA_CRC_KEY.encode()
    data = data.replace(key, b"x" * len(key))  # the key's name damaged in every copy
    path.write_bytes(data)
    with pytest.warns(DamagedLogWarning, match="'run' .it lacks its checksum"):
        assert "run" not in open_log(path).metadata()


def test_metadata_of_other_writers_read_as_they_are(tmp_path):
    from mcap.writer import Writer

    path = tmp_path / "other.mcap"
    with path.open("wb") as fh:
        writer = Writer(fh)
        writer.start(profile="", library="another")
        writer.add_metadata("run", {"seed": "3"})
        writer.finish()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert open_log(path).metadata() == {"run": {"seed": "3"}}


def test_the_checksum_covers_name_keys_and_values():
    crc = contract.metadata_crc
    base = crc("run", {"a": "1", "b": "2"})
    assert base == crc("run", {"b": "2", "a": "1", contract.METADATA_CRC_KEY: "ffffffff"})
    assert len({base, crc("rum", {"a": "1", "b": "2"}), crc("run", {"a": "12", "b": ""})}) == 3
    assert crc("run", {"a": "1", "b": "2"}) != crc("run", {"a": "1", "c": "2"})


def test_the_writer_marks_its_header(tmp_path):
    with LogWriter(tmp_path / "log.mcap") as log:
        log.add_metadata("run", {"k": "v"})
    head = (tmp_path / "log.mcap").read_bytes()[:200]
    assert contract.METADATA_CRC_MARK.encode() in head
    assert struct.unpack_from("<B", head, 8)[0] == 0x01
