"""The summary section of a finished log, checked before the reader believes it.

The footer's summary CRC (mcap's writer computes it) covers every summary record: schemas,
channels, statistics and the chunk, attachment and metadata indexes. A summary whose CRC
does not match, or whose records do not hang together (an index pointing outside the data
section, a duplicated chunk index, statistics whose times or counts disagree with the chunk
indexes), is not used: the reader then reads the log from its data section, as it reads an
unfinished log, and says why.
"""

from __future__ import annotations

import io
import itertools
import os
import struct
import zlib
from dataclasses import dataclass
from typing import IO

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import (
    AttachmentIndex,
    Channel,
    ChunkIndex,
    MetadataIndex,
    Schema,
    Statistics,
)
from mcap.summary import Summary

MAGIC = b"\x89MCAP0\r\n"
_FOOTER = struct.Struct("<BQQQI")  # opcode, length, summary start, offsets start, CRC
_FOOTER_PREFIX = struct.Struct("<BQQQ")  # what the summary CRC covers of the footer
_RECORD = struct.Struct("<BQ")
_TAIL = _FOOTER.size + len(MAGIC)
_CRC_BLOCK = 1 << 20  # bytes read at a time while checking the summary's CRC


@dataclass(frozen=True)
class CheckedSummary:
    """The summary of a log and how far it can be believed.

    ``summary`` is None when the log has none (unfinished, cut, or written without one) or
    when it is damaged; ``damage`` then says what is wrong (None: simply absent).
    ``start`` is the summary section's offset (0 without one); ``crc`` the footer's
    summary CRC (0: not computed by the writer). ``shift``: how many bytes the data
    section grew (shrank, if negative) since the summary was written; the records after the
    change lie that much further than the summary's offsets say."""

    summary: Summary | None
    damage: str | None = None
    start: int = 0
    crc: int = 0
    ends_with_magic: bool = False
    shift: int = 0


def read_checked_summary(fh: IO[bytes]) -> CheckedSummary:
    """The summary of the log open in ``fh``, checked (see the module's docstring)."""
    size = fh.seek(0, os.SEEK_END)
    if size < len(MAGIC) + _TAIL:
        return CheckedSummary(None)
    fh.seek(size - _TAIL)
    tail = fh.read(_TAIL)
    if tail[_FOOTER.size :] != MAGIC:
        return CheckedSummary(None)
    opcode, length, start, offsets, crc = _FOOTER.unpack_from(tail)
    if opcode != Opcode.FOOTER or length != _FOOTER.size - _RECORD.size:
        return CheckedSummary(None, "its footer is damaged", ends_with_magic=True)
    end = size - _TAIL
    if start == 0:
        return CheckedSummary(None, ends_with_magic=True)
    found = start
    inside = len(MAGIC) <= start <= end and (offsets == 0 or start <= offsets <= end)
    if not inside or (crc != 0 and _crc_of(fh, start, end, start, offsets) != crc):
        # A record deleted from the data section (a lost chunk) moves the summary nearer
        # the file's start, past where the footer points when it was near the end.
        moved = _moved_summary(fh, start, end, offsets, crc) if crc != 0 else None
        if moved is None and not inside:
            what = f"its footer points at byte {start}, outside the file"
            return CheckedSummary(None, what, ends_with_magic=True)
        if moved is None:
            what = "its summary section is damaged (the summary CRC does not match)"
            return CheckedSummary(None, what, start, crc, ends_with_magic=True)
        found = moved
    fh.seek(found)
    body = fh.read(end - found)
    try:
        summary = _parsed(body)
    except Exception as exc:  # a record the writer cannot have written
        what = f"its summary section cannot be parsed ({type(exc).__name__}: {exc})"
        return CheckedSummary(None, what, start, crc, ends_with_magic=True)
    stats = summary.statistics
    if stats is None or (stats.message_count and not summary.chunk_indexes):
        # no counts to check against, or messages outside chunks: the data section tells
        return CheckedSummary(None, start=start, crc=crc, ends_with_magic=True)
    problem = inconsistency(summary, max(start, found))
    if problem is not None:
        return CheckedSummary(None, f"its summary {problem}", found, crc, ends_with_magic=True)
    return CheckedSummary(summary, None, found, crc, ends_with_magic=True, shift=found - start)


# DataEnd's opcode and length: the record just before the summary section.
_DATA_END = bytes([Opcode.DATA_END]) + struct.pack("<Q", 4)
_DATA_END_SIZE = _RECORD.size + 4
# How far before the footer a moved summary is looked for, and how many places are tried.
_MOVED_WINDOW = 64 << 20
_MOVED_TRIES = 16


def _moved_summary(fh: IO[bytes], start: int, end: int, offsets: int, crc: int) -> int | None:
    """Where the summary section starts if its records are intact but the data section
    before it changed length (a span inserted or deleted, a record lost or repeated): the
    summary CRC matches the bytes after a DataEnd record found nearer the footer or
    further from it. None if no such place is found."""
    lo = max(len(MAGIC), end - _MOVED_WINDOW)
    fh.seek(lo)
    window = fh.read(end - lo)
    at = len(window)
    for _ in range(_MOVED_TRIES):
        at = window.rfind(_DATA_END, 0, at)
        if at < 0:
            return None
        candidate = lo + at + _DATA_END_SIZE
        if candidate != start and _crc_of(fh, candidate, end, start, offsets) == crc:
            return candidate
    return None


def _crc_of(fh: IO[bytes], begin: int, end: int, start: int, offsets: int) -> int:
    """The summary CRC of the bytes from ``begin`` to ``end`` and a footer holding
    ``start`` and ``offsets``."""
    fh.seek(begin)
    crc = 0
    left = end - begin
    while left > 0:
        block = fh.read(min(left, _CRC_BLOCK))
        if not block:
            break
        crc = zlib.crc32(block, crc)
        left -= len(block)
    prefix = _FOOTER_PREFIX.pack(Opcode.FOOTER, _FOOTER.size - _RECORD.size, start, offsets)
    return zlib.crc32(prefix, crc)


_READERS = {
    Opcode.SCHEMA: Schema.read,
    Opcode.CHANNEL: Channel.read,
    Opcode.CHUNK_INDEX: ChunkIndex.read,
    Opcode.ATTACHMENT_INDEX: AttachmentIndex.read,
    Opcode.METADATA_INDEX: MetadataIndex.read,
    Opcode.STATISTICS: Statistics.read,
}


def _parsed(body: bytes) -> Summary:
    summary = Summary()
    at = 0
    while at < len(body):
        opcode, length = _RECORD.unpack_from(body, at)
        start = at + _RECORD.size
        at = start + length
        if at > len(body):
            msg = f"a record (opcode {opcode:#04x}) runs past the summary's end"
            raise ValueError(msg)
        read = _READERS.get(opcode)
        if read is None:  # summary offsets and unknown records
            continue
        record = read(ReadDataStream(io.BytesIO(body[start:at])))
        if isinstance(record, Schema):
            summary.schemas[record.id] = record
        elif isinstance(record, Channel):
            summary.channels[record.id] = record
        elif isinstance(record, ChunkIndex):
            summary.chunk_indexes.append(record)
        elif isinstance(record, AttachmentIndex):
            summary.attachment_indexes.append(record)
        elif isinstance(record, MetadataIndex):
            summary.metadata_indexes.append(record)
        elif isinstance(record, Statistics):
            if summary.statistics is not None:
                msg = "two statistics records"
                raise ValueError(msg)
            summary.statistics = record
    return summary


def inconsistency(summary: Summary, data_end: int) -> str | None:
    """What makes a parsed summary impossible for the data section ending at ``data_end``
    (None if nothing): the checks a summary without a CRC relies on, and a guard against
    a writer's mistakes for one with it."""
    stats = summary.statistics
    assert stats is not None
    for channel in summary.channels.values():
        if channel.schema_id and channel.schema_id not in summary.schemas:
            return f"gives channel {channel.id} schema {channel.schema_id}, which it lacks"
    unknown = set(stats.channel_message_counts) - set(summary.channels)
    if unknown:
        return f"counts messages on channel(s) {sorted(unknown)}, which it lacks"
    if sum(stats.channel_message_counts.values()) != stats.message_count:
        return (
            f"statistics count {stats.message_count} messages but "
            f"{sum(stats.channel_message_counts.values())} over their channels"
        )
    spans = sorted(
        (c.chunk_start_offset, c.chunk_start_offset + c.chunk_length) for c in summary.chunk_indexes
    )
    for (lo, hi), (next_lo, _) in itertools.pairwise(spans):
        if next_lo < hi:
            return f"indexes overlapping chunks at bytes {lo} and {next_lo}"
    for c in summary.chunk_indexes:
        if c.chunk_start_offset < len(MAGIC) or c.chunk_start_offset + c.chunk_length > data_end:
            return f"indexes a chunk at byte {c.chunk_start_offset}, outside the data section"
        if c.message_start_time > c.message_end_time:
            return f"gives the chunk at byte {c.chunk_start_offset} an end before its start"
        if set(c.message_index_offsets) - set(summary.channels):
            return f"indexes the chunk at byte {c.chunk_start_offset} by unknown channels"
    for a in summary.attachment_indexes:
        if a.offset < len(MAGIC) or a.offset + a.length > data_end:
            return f"indexes attachment '{a.name}' outside the data section"
    for m in summary.metadata_indexes:
        if m.offset < len(MAGIC) or m.offset + m.length > data_end:
            return f"indexes metadata '{m.name}' outside the data section"
    if stats.chunk_count != len(summary.chunk_indexes) and summary.chunk_indexes:
        return f"counts {stats.chunk_count} chunks but indexes {len(summary.chunk_indexes)}"
    if summary.chunk_indexes and stats.message_count:
        first = min(c.message_start_time for c in summary.chunk_indexes)
        last = max(c.message_end_time for c in summary.chunk_indexes)
        if (first, last) != (stats.message_start_time, stats.message_end_time):
            return (
                f"statistics span {stats.message_start_time}-{stats.message_end_time} ns but "
                f"its chunks hold messages from {first} to {last} ns"
            )
    return None
