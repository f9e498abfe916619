"""Streaming MCAP reading: ``for m in open_log(path).messages([ODOM]): ...``.

Messages come in log-time order, decoded into plain values (``flylog.io.decode``), with
bounded memory: a finished log is read chunk by chunk through its checked summary; an
unfinished or cut log, or one whose summary is damaged, is read front to back from its data
section. Damage is never silent: what cannot be read is skipped and a DamagedLogWarning (a
TruncatedLogWarning for a cut log) names it and the messages lost; what cannot be read at
all is a LogError naming the file and the part damaged.
"""

from __future__ import annotations

import os
import struct
import warnings
from collections.abc import Generator, Iterable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO

from mcap.opcode import Opcode
from mcap.records import Metadata
from mcap.summary import Summary

from flylog.errors import LogError
from flylog.io import contract
from flylog.io.chunks import indexed_messages
from flylog.io.decoding import Decoding, schema_name
from flylog.io.indexed import indexed_attachments, indexed_metadata
from flylog.io.inputs import open_input
from flylog.io.pairing import pair_stereo
from flylog.io.readahead import read_ahead as read_ahead_of
from flylog.io.records import LogAttachment, LogMessage, TopicInfo
from flylog.io.scan import (
    DamagedLogWarning,
    RawMessage,
    ScanState,
    TruncatedLogWarning,
    in_log_time_order,
    scan_messages,
)
from flylog.io.summary import MAGIC, CheckedSummary, read_checked_summary
from flylog.sensors import StereoPair


def open_log(path: str | os.PathLike[str]) -> LogReader:
    """Open an MCAP log for reading; LogError if it is missing or not MCAP."""
    path = Path(path)
    try:
        with open_input(path, "the log") as fh:
            magic = fh.read(len(MAGIC))
            library = _header_library(fh.read(_HEADER_BYTES))
            checked = read_checked_summary(fh) if magic == MAGIC else None
    except FileNotFoundError:
        msg = f"{path}: no such file"
        raise LogError(msg) from None
    except IsADirectoryError:
        msg = f"{path} is a directory, not an MCAP file"
        raise LogError(msg) from None
    except OSError as exc:
        msg = f"{path}: cannot be read ({exc.strerror})"
        raise LogError(msg) from None
    if checked is None:
        msg = f"{path} is not an MCAP file (it does not start with the MCAP magic bytes)"
        raise LogError(msg)
    return LogReader(path, checked, library=library)


_HEADER_BYTES = 512  # enough for a Header record of any writer's profile and library names


def _header_library(head: bytes) -> str:
    """The library field of the Header record at the start of ``head`` ("" if none)."""
    try:
        opcode, _ = struct.unpack_from("<BQ", head)
        if opcode != Opcode.HEADER:
            return ""
        (profile,) = struct.unpack_from("<I", head, 9)
        (length,) = struct.unpack_from("<I", head, 13 + profile)
        return head[17 + profile : 17 + profile + length].decode("utf-8")
    except (struct.error, UnicodeDecodeError):
        return ""


def checked_metadata(
    found: Iterable[Metadata], *, required: bool
) -> tuple[list[Metadata], list[str]]:
    """The records of ``found`` whose checksum (``contract.METADATA_CRC_KEY``) matches,
    without it, and a description of each one that fails. ``required``: a record without the
    key fails too (its log's writer adds it to every record)."""
    kept: list[Metadata] = []
    failed: list[str] = []
    for m in found:
        values = dict(m.metadata)
        crc = values.pop(contract.METADATA_CRC_KEY, None)
        if crc is None and required:
            failed.append(f"'{m.name}' (it lacks its checksum)")
            continue
        if crc is not None and crc != contract.metadata_crc(m.name, values):
            failed.append(f"'{m.name}' (its checksum does not match)")
            continue
        kept.append(Metadata(name=m.name, metadata=values))
    return kept, failed


@contextmanager
def _reading(path: Path, what: str) -> Iterator[None]:
    """Any failure but flylog's own while reading ``what`` of ``path`` as a LogError."""
    try:
        yield
    except LogError:
        raise
    except Exception as exc:  # a damaged file can make any parser fail
        msg = f"{path}: {what} is damaged ({type(exc).__name__}: {exc})"
        raise LogError(msg) from None


class LogReader:
    """A log opened for reading. Each iteration opens its own file handle, so several may
    run at once (images and odometry, say) and nothing needs closing.

    A finished log whose summary passes its checks (:mod:`flylog.io.summary`) is read
    chunk by chunk through it; any other is read front to back from its data section."""

    def __init__(self, path: Path, checked: CheckedSummary, *, library: str = "") -> None:
        self.path = path
        self._library = library  # the Header record's: says whether metadata have checksums
        self._checked = checked
        self._summary = checked.summary
        self._scan: ScanState | None = None
        self._scan_count = 0
        self._topics: dict[str, TopicInfo] | None = None
        self._times: tuple[int, int] = (0, 0)
        self._metadata: list[Metadata] | None = None
        self._said: set[str] = set()  # damage already reported

    @property
    def _require_crcs(self) -> bool:
        """Whether an attachment CRC of 0 is damage: unless the footer says its writer
        computes no CRCs (a summary CRC of 0)."""
        return not (self._checked.ends_with_magic and self._checked.crc == 0)

    @property
    def complete(self) -> bool:
        """Whether the log was finished by its writer and its summary is intact."""
        return self._summary is not None

    @property
    def damage(self) -> str | None:
        """What stopped the front-to-back reading of a log without an intact summary
        (None: it reached the end of the data section, or the log has its summary)."""
        return None if self._summary is not None else self._scanned().damage

    # ---- what the log holds ---------------------------------------------------------------

    def _scanned(self) -> ScanState:
        """A front-to-back pass over a log without its summary, for its topics, times and
        records; a DamagedLogWarning names what it had to skip."""
        if self._scan is None:
            state = ScanState(require_crcs=self._require_crcs)
            counts: dict[str, int] = {}
            schemas: dict[str, str] = {}
            lo, hi = None, 0
            with open_input(self.path, "the log") as fh, _reading(self.path, "the data section"):
                for raw in scan_messages(fh, state):
                    topic = raw.channel.topic
                    counts[topic] = counts.get(topic, 0) + 1
                    schemas[topic] = schema_name(raw.schema)
                    t = raw.message.log_time
                    lo = t if lo is None else min(lo, t)
                    hi = max(hi, t)
            self._topics = {t: TopicInfo(schemas[t], counts[t]) for t in sorted(counts)}
            self._times = (lo or 0, hi)
            self._scan = state
            self._scan_count = sum(counts.values())
            report = self._scan_report(state, self._scan_count, None)
            # a cut is reported when messages are read, with what they recovered
            report = [w for w in report if type(w) is not TruncatedLogWarning]
            for w in self._unsaid(report):
                warnings.warn(w, stacklevel=4)
        return self._scan

    def _unsaid(self, report: list[DamagedLogWarning]) -> list[DamagedLogWarning]:
        """The warnings of ``report`` this reader has not given yet (a log whose summary is
        damaged is read whole for its topics, then for its messages: one warning)."""
        out = [w for w in report if str(w) not in self._said]
        self._said.update(str(w) for w in out)
        return out

    def _scan_report(
        self, state: ScanState, count: int, wanted: frozenset[str] | None
    ) -> list[DamagedLogWarning]:
        """The warnings a front-to-back read of ``count`` messages owes its reader."""
        which = "" if wanted is None else f" on {', '.join(sorted(wanted))}"
        out: list[DamagedLogWarning] = []
        if self._checked.damage is not None:
            text = (
                f"{self.path}: {self._checked.damage}; read front to back from its data "
                "section instead"
            )
            out.append(DamagedLogWarning(text))
        if state.skipped:
            lost = f"{state.lost}{' or more' if state.lost_unknown else ''}"
            text = (
                f"{self.path}: skipped damaged records ({'; '.join(state.skipped)}): "
                f"{lost} messages lost, {count} read{which}"
            )
            # the topics of a chunk that cannot be read are unknown: counted under ""
            out.append(DamagedLogWarning(text, {"": state.lost}, exact=not state.lost_unknown))
        if state.damage is not None:
            if self._checked.ends_with_magic:
                text = (
                    f"{self.path}: the log is damaged ({state.damage}): nothing after it "
                    f"can be read; recovered {count} intact messages{which}"
                )
            else:
                text = (
                    f"{self.path}: the log is truncated or unfinished ({state.damage}); "
                    f"recovered {count} intact messages{which}"
                )
            # what followed the damage is unknown (a cut log's counts lay in its summary)
            counted = {"": state.lost} if state.skipped else None
            out.append(TruncatedLogWarning(text, counted, exact=False))
        elif not self._checked.ends_with_magic:
            text = (
                f"{self.path}: the log is truncated inside its summary section (its data "
                f"section is whole); recovered {count} intact messages{which}"
            )
            counted = {"": state.lost} if state.skipped else None
            out.append(TruncatedLogWarning(text, counted, exact=not state.lost_unknown))
        return out

    def topics(self) -> dict[str, TopicInfo]:
        """topic → (schema name, message count), for topics with at least one message."""
        if self._summary is None:
            self._scanned()
            assert self._topics is not None
            return dict(self._topics)
        stats = self._summary.statistics
        assert stats is not None
        out = {}
        for channel_id, count in stats.channel_message_counts.items():
            channel = self._summary.channels[channel_id]
            schema = self._summary.schemas.get(channel.schema_id)
            if count:
                out[channel.topic] = TopicInfo(schema_name(schema), count)
        return dict(sorted(out.items()))

    @property
    def start_ns(self) -> int:
        """Log time of the first message (0 for an empty log)."""
        return self._time_range()[0]

    @property
    def end_ns(self) -> int:
        """Log time of the last message (0 for an empty log)."""
        return self._time_range()[1]

    def _time_range(self) -> tuple[int, int]:
        if self._summary is None:
            self._scanned()
            return self._times
        stats = self._summary.statistics
        assert stats is not None
        return stats.message_start_time, stats.message_end_time

    def attachments(self) -> list[LogAttachment]:
        """The log's attachments; a damaged one (its CRC does not match) is skipped with a
        DamagedLogWarning naming it."""
        if self._summary is None:
            found = self._scanned().attachments
        else:
            with open_input(self.path, "the log") as fh, _reading(self.path, "an attachment"):
                found, skipped = indexed_attachments(
                    fh, self._summary, self._checked.shift, require_crcs=self._require_crcs
                )
            if skipped:
                text = f"{self.path}: skipped damaged attachment(s) {'; '.join(skipped)}"
                warnings.warn(DamagedLogWarning(text), stacklevel=2)
        return [LogAttachment(a.name, a.media_type, a.log_time, a.data) for a in found]

    def metadata(self) -> dict[str, dict[str, str]]:
        """name → key/value pairs of every metadata record (the last wins on a repeated
        name); a damaged record is skipped with a DamagedLogWarning naming it."""
        if self._metadata is None:  # a few small records, asked for by several readers
            skipped: list[str] = []
            if self._summary is None:
                found = self._scanned().metadata
            else:
                with (
                    open_input(self.path, "the log") as fh,
                    _reading(self.path, "a metadata record"),
                ):
                    found, skipped = indexed_metadata(fh, self._summary, self._checked.shift)
            required = self._library.endswith(contract.METADATA_CRC_MARK)
            self._metadata, failed = checked_metadata(found, required=required)
            skipped += failed
            if skipped:
                text = f"{self.path}: skipped damaged metadata {'; '.join(skipped)}"
                warnings.warn(DamagedLogWarning(text), stacklevel=2)
        return {m.name: dict(m.metadata) for m in self._metadata}

    # ---- messages -------------------------------------------------------------------------

    def raw_messages(self, topics: Iterable[str] | None = None) -> Iterator[RawMessage]:
        """Undecoded messages in log-time order (a TruncatedLogWarning at the end if the log
        is damaged). A message's ``data`` is a read-only memoryview of its chunk
        (:mod:`flylog.io.chunks`): ``bytes(data)`` to keep it apart."""
        damage: list[DamagedLogWarning] = []
        yield from self._raw(topics, damage)
        for w in damage:
            warnings.warn(w, stacklevel=3)

    def _raw(
        self, topics: Iterable[str] | None, damage: list[DamagedLogWarning]
    ) -> Iterator[RawMessage]:
        """:meth:`raw_messages` that appends the damage report to ``damage`` instead of
        warning (warnings are process-wide: a reading thread must not issue them)."""
        wanted = None if topics is None else frozenset(topics)
        with open_input(self.path, "the log") as fh:
            if self._summary is not None:
                yield from self._raw_indexed(fh, self._summary, wanted, damage)
                return
            # Here, not at import: the writer's module imports mcap's writer, which looks up
            # its package version (~25 ms of every reading command's start).
            from flylog.io.writer import MAX_WRITE_LAG_NS

            state = ScanState(require_crcs=self._require_crcs)
            count = 0
            with _reading(self.path, "the data section"):
                scanned = scan_messages(fh, state, topics=wanted)
                for raw in in_log_time_order(scanned, MAX_WRITE_LAG_NS):
                    count += 1
                    yield raw
        damage.extend(self._unsaid(self._scan_report(state, count, wanted)))

    def _raw_indexed(
        self,
        fh: BinaryIO,
        summary: Summary,
        wanted: frozenset[str] | None,
        damage: list[DamagedLogWarning],
    ) -> Iterator[RawMessage]:
        """The messages of a log with an intact summary; the count read is checked against
        its statistics, and skipped chunks are reported with the messages they held."""
        skipped: list[str] = []
        read: dict[int, int] = {}  # channel id → messages read
        with _reading(self.path, "a chunk"):
            for raw in indexed_messages(fh, summary, wanted, skipped, self._checked.shift):
                read[raw.channel.id] = read.get(raw.channel.id, 0) + 1
                yield raw
        stats = summary.statistics
        assert stats is not None
        promised = {
            i: n
            for i, n in stats.channel_message_counts.items()
            if wanted is None or summary.channels[i].topic in wanted
        }
        count, listed = sum(read.values()), sum(promised.values())
        lost: dict[str, int] = {}
        for i, n in promised.items():
            topic = summary.channels[i].topic
            lost[topic] = lost.get(topic, 0) + max(0, n - read.get(i, 0))
        shift = self._checked.shift
        if shift:
            text = (
                f"{self.path}: its data section is {abs(shift)} bytes "
                f"{'longer' if shift > 0 else 'shorter'} than its summary says (a span "
                "inserted or lost): the records after that point are read where they lie"
            )
            damage.extend(self._unsaid([DamagedLogWarning(text)]))
        if skipped or count != listed:
            which = "" if wanted is None else f" on {', '.join(sorted(wanted))}"
            where = f"skipped {'; '.join(skipped)}: " if skipped else ""
            text = (
                f"{self.path}: {where}read {count} of the {listed} messages{which} its "
                f"summary lists ({listed - count} lost)"
            )
            damage.append(DamagedLogWarning(text, lost))

    def messages(
        self, topics: Iterable[str] | None = None, *, read_ahead: int = 0
    ) -> Generator[LogMessage, None, None]:
        """Messages in log-time order, each decoded into plain values by its schema.

        With ``read_ahead`` > 0, a background thread reads, decompresses and decodes up to
        that many messages ahead of the consumer (see :mod:`flylog.io.readahead`)."""
        decode = Decoding(self.path)
        damage: list[DamagedLogWarning] = []
        decoded: Iterator[LogMessage] = (decode(raw) for raw in self._raw(topics, damage))
        if read_ahead > 0:
            decoded = read_ahead_of(decoded, read_ahead)
        yield from decoded
        for w in damage:
            warnings.warn(w, stacklevel=2)

    def first(self, topic: str) -> LogMessage:
        """The first message on ``topic``; LogError if none can be read (the topic is
        absent, or every chunk holding it is damaged)."""
        for message in self.messages([topic]):
            return message
        counted = self.topics().get(topic)
        why = "has none" if counted is None else f"lists {counted.count} but none can be read"
        msg = f"{self.path}: no message on {topic} (the log {why})"
        raise LogError(msg)

    def stereo_pairs(self, *, tolerance_ns: int = 5_000_000) -> Iterator[StereoPair]:
        """The log's stereo pairs, streamed (see ``pair_stereo``)."""
        stream = self.messages([contract.LEFT_IMAGE, contract.RIGHT_IMAGE])
        for m in pair_stereo(stream, tolerance_ns=tolerance_ns):
            yield m.value


def require_topics(reader: LogReader, needed: Iterable[str] | Mapping[str, str]) -> None:
    """LogError unless every needed topic has messages with the expected schema (the
    contract's, or the mapping's topic → schema name)."""
    expected = (
        dict(needed)
        if isinstance(needed, Mapping)
        else {t: contract.TOPIC_SCHEMAS.get(t) for t in needed}
    )
    present = reader.topics()
    missing = [t for t in expected if t not in present]
    if missing and reader.damage is not None and not present:
        msg = f"{reader.path} is truncated or damaged ({reader.damage}): it holds no messages"
        raise LogError(msg)
    if missing:
        listing = ", ".join(f"{t} ({i.schema})" for t, i in present.items()) or "none"
        msg = (
            f"{reader.path} lacks topic(s) {', '.join(missing)}; the topics present are: {listing}"
        )
        raise LogError(msg)
    for topic, schema in expected.items():
        if schema is not None and present[topic].schema != schema:
            msg = (
                f"{reader.path}: topic {topic} should carry {schema} "
                f"but carries {present[topic].schema or 'no schema'}"
            )
            raise LogError(msg)
