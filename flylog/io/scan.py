"""Reading an MCAP file front to back without its summary: how unfinished logs (writer
killed, no footer) and logs cut anywhere, even inside a chunk, are read up to the damage.

Every record is read whole (its length is in its header) before it is parsed, so a cut
record is recognised as damage rather than half-parsed; chunks are CRC-checked.
"""

from __future__ import annotations

import heapq
import io
import itertools
import struct
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import IO

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Attachment, Channel, Message, Metadata, Schema

from flylog.io.chunks import RawMessage, chunk_records

__all__ = ["MAGIC", "RawMessage", "ScanState", "TruncatedLogWarning", "scan_messages"]

MAGIC = b"\x89MCAP0\r\n"
# A record longer than this is taken for corruption rather than read into memory.
MAX_RECORD_BYTES = 1 << 31


class TruncatedLogWarning(UserWarning):
    """A log ended early (unfinished or cut); everything before the damage was read."""


@dataclass
class ScanState:
    """What a front-to-back scan found: records that describe the log, and the damage."""

    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    attachments: list[Attachment] = field(default_factory=list)
    metadata: list[Metadata] = field(default_factory=list)
    damage: str | None = None  # None: the scan reached the footer


class _Damaged(Exception):
    """Internal: the file cannot be read past this point."""


def _read_record(fh: IO[bytes], offset: int) -> tuple[int, bytes] | None:
    """(opcode, body) of the record at ``offset``; None at the footer."""
    head = fh.read(9)
    if len(head) < 9:
        what = "ends" if not head else "is cut inside a record header"
        msg = f"file {what} at byte {offset} without a footer"
        raise _Damaged(msg)
    opcode, length = struct.unpack("<BQ", head)
    if length > MAX_RECORD_BYTES:
        msg = f"record at byte {offset} claims {length} bytes"
        raise _Damaged(msg)
    body = fh.read(length)
    if len(body) < length:
        msg = f"file is cut inside a record (opcode {opcode:#04x}) starting at byte {offset}"
        raise _Damaged(msg)
    return None if opcode == Opcode.FOOTER else (opcode, body)


def _parse(opcode: int, body: bytes) -> list[object]:
    """The records a record body holds (a chunk holds several)."""
    if opcode == Opcode.CHUNK:
        return [record for _, record in chunk_records(body)]
    stream = ReadDataStream(io.BytesIO(body))
    if opcode == Opcode.MESSAGE:
        return [Message.read(stream, len(body))]
    readers: dict[int, Callable[[ReadDataStream], object]] = {
        Opcode.SCHEMA: Schema.read,
        Opcode.CHANNEL: Channel.read,
        Opcode.ATTACHMENT: Attachment.read,
        Opcode.METADATA: Metadata.read,
    }
    read = readers.get(opcode)
    return [] if read is None else [read(stream)]  # indexes etc. are not needed here


def scan_messages(
    fh: IO[bytes], state: ScanState, *, topics: frozenset[str] | None = None
) -> Iterator[RawMessage]:
    """Messages in file order, read up to the footer or the first damage (then recorded in
    ``state.damage``). ``fh`` is positioned at the start of the file."""
    if fh.read(8) != MAGIC:
        state.damage = "the file does not start with the MCAP magic"
        return
    offset = 8
    while True:
        try:
            found = _read_record(fh, offset)
            if found is None:
                return
            opcode, body = found
            # Any failure to parse a complete record (bad CRC, bad compressed data,
            # inconsistent lengths) is damage; what came before it stays readable.
            try:
                records = _parse(opcode, body)
            except Exception as exc:
                msg = f"record at byte {offset} is corrupt ({type(exc).__name__}: {exc})"
                raise _Damaged(msg) from None
        except _Damaged as exc:
            state.damage = str(exc)
            return
        offset += 9 + len(body)
        for record in records:
            if isinstance(record, Message):
                channel = state.channels.get(record.channel_id)
                if channel is None:
                    state.damage = f"message for unknown channel {record.channel_id}"
                    return
                if topics is None or channel.topic in topics:
                    yield RawMessage(state.schemas.get(channel.schema_id), channel, record)
            elif isinstance(record, Schema):
                state.schemas[record.id] = record
            elif isinstance(record, Channel):
                state.channels[record.id] = record
            elif isinstance(record, Attachment):
                state.attachments.append(record)
            elif isinstance(record, Metadata):
                state.metadata.append(record)


def in_log_time_order(messages: Iterator[RawMessage], window_ns: int) -> Iterator[RawMessage]:
    """Messages merged into log-time order through a buffer of ``window_ns`` of log time.

    Exact when no message was written more than ``window_ns`` behind the newest message
    written before it (LogWriter enforces this); ties keep file order, as the summary-based
    reader does. Memory: the messages of one window."""
    heap: list[tuple[int, int, RawMessage]] = []
    newest = 0
    counter = itertools.count()
    for raw in messages:
        t = raw.message.log_time
        newest = max(newest, t)
        heapq.heappush(heap, (t, next(counter), raw))
        while heap[0][0] < newest - window_ns:
            yield heapq.heappop(heap)[2]
    while heap:
        yield heapq.heappop(heap)[2]
