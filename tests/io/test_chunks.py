"""Chunks parsed without copies: the same records, CRC check and log-time order as mcap's
reader, on logs whose chunks overlap in time, for every compression."""

from __future__ import annotations

import io
import itertools
import struct

import pytest
from mcap.data_stream import ReadDataStream
from mcap.reader import SeekingReader
from mcap.records import Channel, Chunk, Message, Schema
from mcap.stream_reader import breakup_chunk
from mcap.writer import CompressionType, Writer

from flylog.io.chunks import chunk_records, indexed_messages
from tests.io.conftest import write_sample


def _chunk_bodies(path) -> list[bytes]:
    """The body (after opcode and length) of every chunk record of a finished log."""
    data = path.read_bytes()
    with path.open("rb") as fh:
        summary = SeekingReader(fh).get_summary()
    assert summary is not None
    return [
        data[c.chunk_start_offset + 9 : c.chunk_start_offset + c.chunk_length]
        for c in summary.chunk_indexes
    ]


def _key(record) -> tuple:
    if isinstance(record, Message):
        return (
            "m",
            record.channel_id,
            record.sequence,
            record.log_time,
            record.publish_time,
            bytes(record.data),
        )
    return (type(record).__name__, record.id)


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_chunk_records_are_mcaps_records(tmp_path, compression):
    sample = write_sample(tmp_path / "log.mcap", compression=compression, chunk_size=4096)
    bodies = _chunk_bodies(sample.path)
    assert len(bodies) > 3
    for body in bodies:
        theirs = breakup_chunk(Chunk.read(ReadDataStream(io.BytesIO(body))), validate_crc=True)
        ours = chunk_records(body)
        assert [i for i, _ in ours] == list(range(len(theirs)))
        assert [_key(r) for _, r in ours] == [_key(r) for r in theirs]
        for _, record in ours:
            if isinstance(record, Message):  # a view of the chunk, which nobody may change
                assert isinstance(record.data, memoryview) and record.data.readonly


def test_a_chunk_whose_data_changed_fails_its_crc(tmp_path):
    sample = write_sample(tmp_path / "log.mcap", compression="none", chunk_size=4096)
    body = bytearray(_chunk_bodies(sample.path)[1])
    body[-5] ^= 0xFF  # inside the last message's data
    with pytest.raises(ValueError, match="chunk CRC mismatch"):
        chunk_records(bytes(body))


def test_a_chunk_cut_short_is_refused(tmp_path):
    sample = write_sample(tmp_path / "log.mcap", compression="none", chunk_size=4096)
    body = _chunk_bodies(sample.path)[1]
    with pytest.raises(ValueError, match="runs past its record"):
        chunk_records(body[:-10])


def _overlapping_log(path, compression: CompressionType) -> None:
    """Two topics written out of log-time order (each chunk spans times the next one also
    spans), with equal log times across topics and chunks."""
    with path.open("wb") as fh:
        writer = Writer(fh, chunk_size=300, compression=compression)
        writer.start()
        schema = writer.register_schema("raw", "", b"")
        a = writer.register_channel("/a", "bytes", schema)
        b = writer.register_channel("/b", "bytes", schema)
        for k in range(60):
            t = (k // 3) * 10 + (7 if k % 3 == 0 else 0)  # later, then earlier times
            writer.add_message(a, t, struct.pack("<I", k) * 8, t, k)
            writer.add_message(b, t, struct.pack("<I", 1000 + k) * 8, t, k)
        writer.finish()


@pytest.mark.parametrize("compression", [CompressionType.NONE, CompressionType.LZ4])
@pytest.mark.parametrize("topics", [None, ["/b"], ["/a", "/b"], []])
def test_indexed_messages_come_in_mcaps_log_time_order(tmp_path, compression, topics):
    path = tmp_path / "overlap.mcap"
    _overlapping_log(path, compression)
    with path.open("rb") as fh:
        reader = SeekingReader(fh, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None and len(summary.chunk_indexes) > 5
        chunks = summary.chunk_indexes
        assert any(b.message_start_time < a.message_end_time for a, b in itertools.pairwise(chunks))
        theirs = [
            (c.topic, m.log_time, bytes(m.data))
            for _, c, m in reader.iter_messages(topics=topics, log_time_order=True)
        ]
        ours = [
            (r.channel.topic, r.message.log_time, bytes(r.message.data))
            for r in indexed_messages(fh, summary, topics)
        ]
    assert ours == theirs
    assert len(ours) == {None: 120, 1: 60, 2: 120, 0: 0}[None if topics is None else len(topics)]
    times = [t for _, t, _ in ours]
    assert times == sorted(times)


def test_schemas_and_channels_inside_chunks_are_parsed(tmp_path):
    path = tmp_path / "overlap.mcap"
    _overlapping_log(path, CompressionType.NONE)
    kinds = {type(r) for body in _chunk_bodies(path) for _, r in chunk_records(body)}
    assert kinds == {Schema, Channel, Message}
