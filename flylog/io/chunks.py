"""A log's chunks parsed without copying messages out of them.

mcap's reader copies every message out of its decompressed chunk (a ``BytesIO.read`` per
record, holding the GIL: the 1.7 GB of images of replay's 60 s reference log) and parses each
record through several small reads. Here a chunk is read in one ``read``, decompressed and
CRC-checked once, and its records are parsed by ``struct.unpack_from`` over that one buffer:
each message's ``data`` is a read-only memoryview of the decompressed chunk (it keeps the
chunk alive while it lives). Same messages, same CRC check, and :func:`indexed_messages`
yields them in the same order as mcap's ``SeekingReader.iter_messages(log_time_order=True)``.
"""

from __future__ import annotations

import heapq
import io
import struct
import zlib
from collections.abc import Iterable, Iterator
from typing import IO, NamedTuple

from mcap.data_stream import ReadDataStream
from mcap.exceptions import UnsupportedCompressionError
from mcap.opcode import Opcode
from mcap.records import Channel, ChunkIndex, Message, Schema
from mcap.summary import Summary

_RECORD = struct.Struct("<BQ")  # opcode, body length
_CHUNK = struct.Struct("<QQQII")  # start, end, uncompressed size, CRC, compression's length
_LENGTH = struct.Struct("<Q")
_MESSAGE = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time

ChunkRecord = Message | Schema | Channel


class RawMessage(NamedTuple):
    """A message as stored: its schema and channel records and the undecoded record."""

    schema: Schema | None
    channel: Channel
    message: Message


def chunk_records(body: bytes | memoryview) -> list[tuple[int, ChunkRecord]]:
    """The messages, schemas and channels of a chunk record's ``body`` (what follows its
    opcode and length), each with its index among them (mcap's ``breakup_chunk`` order),
    after checking the chunk's CRC. A message's ``data`` is a read-only memoryview of the
    decompressed chunk. ValueError (or the decompressor's error) if the chunk is damaged."""
    view = memoryview(body)
    _, _, size, crc, name_length = _CHUNK.unpack_from(view, 0)
    at = _CHUNK.size
    compression = str(view[at : at + name_length], "utf-8")
    at += name_length
    (data_length,) = _LENGTH.unpack_from(view, at)
    at += _LENGTH.size
    if at + data_length > len(view):
        msg = f"chunk data of {data_length} bytes runs past its record"
        raise ValueError(msg)
    data = _decompressed(compression, view[at : at + data_length], size)
    if crc != 0:
        actual = zlib.crc32(data)
        if actual != crc:
            msg = f"chunk CRC mismatch: expected {crc}, calculated {actual}"
            raise ValueError(msg)
    return _records(memoryview(data).toreadonly())


def _decompressed(compression: str, data: memoryview, size: int) -> bytes | memoryview:
    if compression == "lz4":
        import lz4.frame  # as mcap does: only for logs that need it

        return lz4.frame.decompress(data)
    if compression == "zstd":
        import zstandard

        return zstandard.decompress(data, size)
    if compression == "":
        return data
    raise UnsupportedCompressionError(compression)


def _records(data: memoryview) -> list[tuple[int, ChunkRecord]]:
    out: list[tuple[int, ChunkRecord]] = []
    end = len(data)
    at = 0
    while at < end:
        opcode, length = _RECORD.unpack_from(data, at)
        start = at + _RECORD.size
        at = start + length
        if at > end:
            msg = f"a record (opcode {opcode:#04x}) runs past the end of its chunk"
            raise ValueError(msg)
        if opcode == Opcode.MESSAGE:
            if length < _MESSAGE.size:
                msg = f"a message record of {length} bytes is shorter than its header"
                raise ValueError(msg)
            channel_id, sequence, log_time, publish_time = _MESSAGE.unpack_from(data, start)
            record: ChunkRecord = Message(
                channel_id=channel_id,
                sequence=sequence,
                log_time=log_time,
                publish_time=publish_time,
                data=data[start + _MESSAGE.size : at],  # type: ignore[arg-type]
            )
        elif opcode in (Opcode.SCHEMA, Opcode.CHANNEL):  # rare and small: mcap parses them
            stream = ReadDataStream(io.BytesIO(data[start:at]))
            record = Schema.read(stream) if opcode == Opcode.SCHEMA else Channel.read(stream)
        else:  # other records have no place in a chunk; mcap skips them too
            continue
        out.append((len(out), record))
    return out


def indexed_messages(
    fh: IO[bytes],
    summary: Summary,
    topics: Iterable[str] | None = None,
    skipped: list[str] | None = None,
    shift: int = 0,
) -> Iterator[RawMessage]:
    """The messages on ``topics`` (all if None) of a log with a summary, in log-time order,
    ties in file order: chunks are read when their start time comes up and merged with the
    messages of the chunks read before (a heap keyed by log time, chunk offset, index).

    A chunk that cannot be read (not where its index says, not the chunk its index
    describes, a CRC mismatch, bad compressed data) is skipped and named in ``skipped``
    (ValueError when ``skipped`` is None). With a ``shift`` (the data section changed
    length: :class:`flylog.io.summary.CheckedSummary`), a chunk not found where its index
    says is looked for ``shift`` bytes further."""
    wanted = None if topics is None else frozenset(topics)
    channels, schemas = summary.channels, summary.schemas
    ids = None if wanted is None else {i for i, c in channels.items() if c.topic in wanted}
    heap: list[tuple[int, int, int, ChunkIndex | RawMessage]] = [
        (c.message_start_time, c.chunk_start_offset, -1, c)
        for c in summary.chunk_indexes
        # without message indexes a chunk's topics are unknown until it is read
        if ids is None or not c.message_index_offsets or not ids.isdisjoint(c.message_index_offsets)
    ]
    heapq.heapify(heap)
    while heap:
        _, offset, index, item = heapq.heappop(heap)
        if isinstance(item, RawMessage):
            yield item
            continue
        try:
            records = _chunk_at(fh, item, shift)
            found = []
            for index, record in records:
                if not isinstance(record, Message):
                    continue
                channel = channels.get(record.channel_id)
                if channel is None:
                    msg = f"a message of channel {record.channel_id}, which the summary lacks"
                    raise ValueError(msg)
                if wanted is not None and channel.topic not in wanted:
                    continue
                schema = schemas[channel.schema_id] if channel.schema_id else None
                found.append((record.log_time, offset, index, RawMessage(schema, channel, record)))
        except Exception as exc:  # damage inside the chunk, or where it should be
            if skipped is None:
                raise
            skipped.append(
                f"the chunk at byte {item.chunk_start_offset} ({type(exc).__name__}: {exc})"
            )
            continue
        for entry in found:
            heapq.heappush(heap, entry)


def _chunk_at(fh: IO[bytes], index: ChunkIndex, shift: int) -> list[tuple[int, ChunkRecord]]:
    try:
        return _read_chunk(fh, index)
    except Exception:
        if not shift:
            raise
    return _read_chunk(fh, index, shift)


def _read_chunk(fh: IO[bytes], index: ChunkIndex, shift: int = 0) -> list[tuple[int, ChunkRecord]]:
    fh.seek(index.chunk_start_offset + shift)
    record = fh.read(index.chunk_length)
    if len(record) < _RECORD.size + _CHUNK.size:
        msg = f"the chunk at byte {index.chunk_start_offset} lies past the end of the file"
        raise ValueError(msg)
    opcode, length = _RECORD.unpack_from(record, 0)
    if opcode != Opcode.CHUNK or _RECORD.size + length != len(record):
        msg = f"the chunk index points at byte {index.chunk_start_offset}, not at a chunk"
        raise ValueError(msg)
    records = chunk_records(memoryview(record)[_RECORD.size : _RECORD.size + length])
    # The chunk's CRC vouches for its messages; their times say whether it is the chunk
    # the index describes (a duplicated or moved record puts another chunk there).
    times = [r.log_time for _, r in records if isinstance(r, Message)]
    if times and (min(times), max(times)) != (index.message_start_time, index.message_end_time):
        msg = (
            f"the chunk at byte {index.chunk_start_offset} holds messages from {min(times)} "
            f"to {max(times)} ns, its index says {index.message_start_time} to "
            f"{index.message_end_time} ns"
        )
        raise ValueError(msg)
    return records
