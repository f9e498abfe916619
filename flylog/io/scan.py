"""Reading an MCAP file front to back without its summary: how unfinished logs (writer
killed, no footer), logs cut anywhere, even inside a chunk, and logs whose summary is
damaged are read from their data section.

Every record is read whole (its length is in its header) before it is parsed, so a cut
record is recognised as damage rather than half-parsed; chunks and attachments are
CRC-checked. A whole record that fails is skipped and the reading goes on; damage that
hides where the next record starts is read past to the next intact compressed chunk.
"""

from __future__ import annotations

import heapq
import io
import itertools
import mmap
import struct
import zlib
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import IO, Any

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Attachment, Channel, Message, Metadata, Schema

from flylog.io.chunks import RawMessage, chunk_records
from flylog.io.summary import MAGIC

__all__ = [
    "MAGIC",
    "DamagedLogWarning",
    "RawMessage",
    "ScanState",
    "TruncatedLogWarning",
    "messages_lost",
    "scan_messages",
]

# A record longer than this is taken for corruption rather than read into memory.
MAX_RECORD_BYTES = 1 << 31


class DamagedLogWarning(UserWarning):
    """A log is damaged: the warning names what was skipped and how many messages it held;
    everything else was read.

    ``lost`` counts the messages lost by topic (``""``: topics unknown, the channel records
    of a front-to-back reading say nothing about a chunk they cannot read); ``exact`` is
    False when some were lost uncounted (a cut log, whose counts lay in its summary, or a
    span read past with no index of what it held): then ``lost`` is a lower bound. A warning
    about damage that loses no message has ``lost`` empty. :func:`messages_lost` totals the
    warnings of several readings of one log."""

    def __init__(
        self, text: str, lost: Mapping[str, int] | None = None, *, exact: bool = True
    ) -> None:
        super().__init__(text)
        self.lost: dict[str, int] = {k: v for k, v in (lost or {}).items() if v}
        self.exact = exact

    def __reduce__(self) -> tuple[Any, ...]:  # the counts travel with it between processes
        return (_rebuilt, (type(self), str(self), self.lost, self.exact))


def _rebuilt(
    cls: type[DamagedLogWarning], text: str, lost: dict[str, int], exact: bool
) -> DamagedLogWarning:
    return cls(text, lost, exact=exact)


class TruncatedLogWarning(DamagedLogWarning):
    """A log ended early (unfinished or cut); everything before the damage was read."""


def messages_lost(found: Iterable[Warning]) -> tuple[int, bool]:
    """The messages the DamagedLogWarnings in ``found`` say were lost, and whether the count
    is exact. Several readings of one log (its images, then its odometry, say) report the
    same topic's loss each: a topic counts its largest loss once."""
    most: dict[str, int] = {}
    exact = True
    for w in found:
        if isinstance(w, DamagedLogWarning):
            exact = exact and w.exact
            for topic, n in w.lost.items():
                most[topic] = max(most.get(topic, 0), n)
    return sum(most.values()), exact


@dataclass
class ScanState:
    """What a front-to-back scan found: records that describe the log, and the damage."""

    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    attachments: list[Attachment] = field(default_factory=list)
    metadata: list[Metadata] = field(default_factory=list)
    damage: str | None = None  # None: the scan reached the end of the data section
    skipped: list[str] = field(default_factory=list)  # damaged records read past
    lost: int = 0  # messages the skipped chunks held (by their message indexes)
    lost_unknown: bool = False  # a skipped chunk whose message count is unknown
    unknown_channels: set[int] = field(default_factory=set)
    seen: dict[tuple[int, int, bytes], int] = field(default_factory=dict)  # record → offset
    require_crcs: bool = True  # an attachment CRC of 0 is damage (see checked_attachment)


class _Damaged(Exception):
    """Internal: the file cannot be read past this point."""


def _read_record(fh: IO[bytes], offset: int) -> tuple[int, bytes] | None:
    """(opcode, body) of the record at ``offset``; None at the end of the data section."""
    head = fh.read(9)
    if len(head) < 9:
        what = "ends" if not head else "is cut inside a record header"
        msg = f"file {what} at byte {offset} without a footer"
        raise _Damaged(msg)
    opcode, length = struct.unpack("<BQ", head)
    if length > MAX_RECORD_BYTES:
        msg = f"record at byte {offset} claims {length} bytes"
        raise _Damaged(msg)
    if not Opcode.HEADER <= opcode <= MAX_OPCODE:
        msg = f"no MCAP record starts at byte {offset} (opcode {opcode:#04x})"
        raise _Damaged(msg)
    body = fh.read(length)
    if len(body) < length:
        msg = f"file is cut inside a record (opcode {opcode:#04x}) starting at byte {offset}"
        raise _Damaged(msg)
    # the summary section follows DataEnd; its records repeat what the data section holds
    return None if opcode in (Opcode.DATA_END, Opcode.FOOTER) else (opcode, body)


# The highest opcode of the MCAP records (DataEnd); a higher one is taken for damage.
MAX_OPCODE = 0x0F
# A compressed chunk's compression field: its length and name, 37 bytes into the record.
_CHUNK_MARKERS = (b"\x03\x00\x00\x00lz4", b"\x04\x00\x00\x00zstd")
_MARKER_AT = 9 + 28


def next_chunk(fh: IO[bytes], start: int) -> int | None:
    """The offset of the first intact compressed chunk at or after byte ``start`` (its
    compression field found, then the whole record parsed and CRC-checked), or None.

    How a front-to-back reading resumes after damage that hides where the next record
    starts (an inserted or deleted span): the chunks after it are whole. Chunks without
    compression have no field distinctive enough to search for; none are found."""
    try:
        view = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
    except (OSError, ValueError, io.UnsupportedOperation):
        return None
    with view:
        at = {m: view.find(m, start + _MARKER_AT) for m in _CHUNK_MARKERS}
        while any(p >= 0 for p in at.values()):
            marker = min((p, m) for m, p in at.items() if p >= 0)[1]
            where = at[marker] - _MARKER_AT
            at[marker] = view.find(marker, at[marker] + 1)
            opcode, length = struct.unpack_from("<BQ", view, where)
            if opcode != Opcode.CHUNK or where + 9 + length > len(view):
                continue
            try:
                chunk_records(view[where + 9 : where + 9 + length])
            except Exception:  # not a chunk, or a damaged one: search on
                continue
            return where
    return None


_ATTACHMENT_CRC = struct.Struct("<I")


def checked_attachment(body: bytes, *, require_crc: bool = True) -> Attachment:
    """An attachment record, after checking its CRC. A CRC of 0 means "not computed"; with
    ``require_crc`` it is damage: a writer that computes CRCs (mcap's, flylog's) always
    does, and a record read where another one's bytes now lie can end in four zeroes."""
    record = Attachment.read(ReadDataStream(io.BytesIO(body)))
    if len(body) < _ATTACHMENT_CRC.size:
        msg = "attachment record shorter than its CRC"
        raise ValueError(msg)
    (crc,) = _ATTACHMENT_CRC.unpack_from(body, len(body) - _ATTACHMENT_CRC.size)
    if crc == 0 and require_crc:
        msg = f"attachment '{record.name}' has no CRC, where its log's writer computes them"
        raise ValueError(msg)
    if crc != 0 and zlib.crc32(memoryview(body)[: -_ATTACHMENT_CRC.size]) != crc:
        msg = f"attachment '{record.name}' CRC mismatch"
        raise ValueError(msg)
    return record


def _parse(opcode: int, body: bytes, require_crcs: bool) -> list[object]:
    """The records a record body holds (a chunk holds several)."""
    if opcode == Opcode.CHUNK:
        return [record for _, record in chunk_records(body)]
    stream = ReadDataStream(io.BytesIO(body))
    if opcode == Opcode.MESSAGE:
        return [Message.read(stream, len(body))]
    if opcode == Opcode.ATTACHMENT:
        return [checked_attachment(body, require_crc=require_crcs)]
    readers: dict[int, Callable[[ReadDataStream], object]] = {
        Opcode.SCHEMA: Schema.read,
        Opcode.CHANNEL: Channel.read,
        Opcode.METADATA: Metadata.read,
    }
    read = readers.get(opcode)
    return [] if read is None else [read(stream)]  # indexes etc. are not needed here


_MESSAGE_INDEX = struct.Struct("<HI")  # channel id, length of its entries


def _indexed_count(body: bytes) -> int | None:
    """How many messages a message index record lists (None if it is malformed)."""
    if len(body) < _MESSAGE_INDEX.size:
        return None
    _, length = _MESSAGE_INDEX.unpack_from(body)
    if length % 16 or _MESSAGE_INDEX.size + length != len(body):
        return None
    return length // 16


_NAMES: dict[int, str] = {
    Opcode.CHUNK: "chunk",
    Opcode.MESSAGE: "message",
    Opcode.SCHEMA: "schema",
    Opcode.CHANNEL: "channel",
    Opcode.ATTACHMENT: "attachment",
    Opcode.METADATA: "metadata",
}


def scan_messages(
    fh: IO[bytes], state: ScanState, *, topics: frozenset[str] | None = None
) -> Iterator[RawMessage]:
    """Messages in file order, read up to the end of the data section or the first damage
    that hides what follows (then recorded in ``state.damage``). A whole record that fails
    its checks (a chunk's or attachment's CRC, bad compressed data, inconsistent lengths)
    is skipped and named in ``state.skipped``; the messages a skipped chunk held (as its
    message indexes list them) are counted in ``state.lost``. ``fh`` is positioned at the
    start of the file."""
    if fh.read(8) != MAGIC:
        state.damage = "the file does not start with the MCAP magic"
        return
    offset = 8
    counting = False  # the message indexes that follow a skipped chunk are being counted
    while True:
        try:
            found = _read_record(fh, offset)
        except _Damaged as exc:
            resume = next_chunk(fh, offset + 1)
            if resume is None:
                state.damage = str(exc)
                return
            state.skipped.append(f"bytes {offset} to {resume} ({exc})")
            state.lost_unknown = True
            counting = False
            offset = resume
            fh.seek(offset)
            continue
        if found is None:
            return
        opcode, body = found
        at = offset
        offset += 9 + len(body)
        if opcode == Opcode.MESSAGE_INDEX:
            if counting:
                count = _indexed_count(body)
                if count is None:
                    state.lost_unknown = True
                else:
                    state.lost += count
            continue
        if counting and opcode != Opcode.MESSAGE_INDEX:
            counting = False
        if opcode in (Opcode.CHUNK, Opcode.ATTACHMENT):
            # a record repeated byte for byte (a writer's retry, a bad copy) is read once;
            # a chunk's header holds its times, sizes and CRC, an attachment ends in its CRC
            key = (opcode, len(body), body[:36] if opcode == Opcode.CHUNK else body[-36:])
            first = state.seen.setdefault(key, at)
            if first != at:
                what = _NAMES[opcode]
                state.skipped.append(f"the {what} at byte {at} (a copy of the one at byte {first})")
                continue
        try:
            records = _parse(opcode, body, state.require_crcs)
        except Exception as exc:
            what = _NAMES.get(opcode, f"record (opcode {opcode:#04x})")
            state.skipped.append(f"the {what} at byte {at} ({type(exc).__name__}: {exc})")
            if opcode == Opcode.CHUNK:
                counting = True
            elif opcode == Opcode.MESSAGE:
                state.lost += 1
            continue
        for record in records:
            if isinstance(record, Message):
                channel = state.channels.get(record.channel_id)
                lacking = (
                    "channel"
                    if channel is None
                    else "schema"
                    if channel.schema_id and channel.schema_id not in state.schemas
                    else None
                )
                if lacking is not None:  # that record was in a skipped chunk
                    if record.channel_id not in state.unknown_channels:
                        state.unknown_channels.add(record.channel_id)
                        state.skipped.append(
                            f"the messages of channel {record.channel_id} from byte {at} on "
                            f"(its {lacking} record is lost)"
                        )
                    state.lost += 1
                    continue
                assert channel is not None
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
