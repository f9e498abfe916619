"""Streaming MCAP reading: ``for m in open_log(path).messages([ODOM]): ...``.

Messages come in log-time order, decoded into plain values (``flylog.io.decode``), with
bounded memory: a finished log is read chunk by chunk through its index; an unfinished or
cut log is read front to back up to the damage, then a TruncatedLogWarning says so.
"""

from __future__ import annotations

import json
import os
import warnings
from collections.abc import Callable, Generator, Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any, BinaryIO

from mcap.reader import SeekingReader
from mcap.records import Channel, Metadata, Schema
from mcap.summary import Summary
from mcap_protobuf.decoder import DecoderFactory

from flylog.errors import LogError
from flylog.io import contract
from flylog.io.chunks import indexed_messages
from flylog.io.decode import DECODERS, image, is_foxglove_raw_image, raw_image_fields
from flylog.io.pairing import pair_stereo
from flylog.io.readahead import read_ahead as read_ahead_of
from flylog.io.records import LogAttachment, LogMessage, TopicInfo
from flylog.io.scan import (
    MAGIC,
    RawMessage,
    ScanState,
    TruncatedLogWarning,
    in_log_time_order,
    scan_messages,
)
from flylog.sensors import StereoPair


def open_log(path: str | os.PathLike[str]) -> LogReader:
    """Open an MCAP log for reading; LogError if it is missing or not MCAP."""
    path = Path(path)
    try:
        with path.open("rb") as fh:
            magic = fh.read(len(MAGIC))
    except FileNotFoundError:
        msg = f"{path}: no such file"
        raise LogError(msg) from None
    except IsADirectoryError:
        msg = f"{path} is a directory, not an MCAP file"
        raise LogError(msg) from None
    except OSError as exc:
        msg = f"{path}: cannot be read ({exc.strerror})"
        raise LogError(msg) from None
    if magic != MAGIC:
        msg = f"{path} is not an MCAP file (it does not start with the MCAP magic bytes)"
        raise LogError(msg)
    return LogReader(path, _read_summary(path))


def _read_summary(path: Path) -> Summary | None:
    """The summary section, or None if the log has none or its end is damaged."""
    try:
        with path.open("rb") as fh:
            fh.seek(-len(MAGIC), os.SEEK_END)
            if fh.read() != MAGIC:
                return None
            fh.seek(0)
            summary = SeekingReader(fh).get_summary()
    except Exception:  # a damaged end is what the front-to-back path is for
        return None
    if summary is None or summary.statistics is None:
        return None
    return summary


class LogReader:
    """A log opened for reading. Each iteration opens its own file handle, so several may
    run at once (images and odometry, say) and nothing needs closing."""

    def __init__(self, path: Path, summary: Summary | None) -> None:
        self.path = path
        self._summary = summary
        self._scan: ScanState | None = None
        self._topics: dict[str, TopicInfo] | None = None
        self._times: tuple[int, int] = (0, 0)
        self._metadata: list[Metadata] | None = None

    def _indexed(self, fh: BinaryIO, *, validate_crcs: bool = False) -> SeekingReader:
        """mcap's reader over ``fh`` of a finished log, given the summary read at open.

        Why: mcap's SeekingReader parses the whole summary section on first use (every chunk
        and message index: ~1500 records, ~20 ms, on the reference 60 s run) and keeps it
        in ``_summary``; each attachment, metadata or message query makes a new reader.
        """
        reader = SeekingReader(fh, validate_crcs=validate_crcs)
        reader._summary = self._summary  # mcap 1.x's cache; a renamed one is only a miss
        return reader

    @property
    def complete(self) -> bool:
        """Whether the log was finished by its writer (it has a summary)."""
        return self._summary is not None

    # ---- what the log holds ---------------------------------------------------------------

    def _scanned(self) -> ScanState:
        """A front-to-back pass over an unfinished log, for its topics, times and records."""
        if self._scan is None:
            state = ScanState()
            counts: dict[str, int] = {}
            schemas: dict[str, str] = {}
            lo, hi = None, 0
            with self.path.open("rb") as fh:
                for raw in scan_messages(fh, state):
                    topic = raw.channel.topic
                    counts[topic] = counts.get(topic, 0) + 1
                    schemas[topic] = _schema_name(raw.schema)
                    t = raw.message.log_time
                    lo = t if lo is None else min(lo, t)
                    hi = max(hi, t)
            self._topics = {t: TopicInfo(schemas[t], counts[t]) for t in sorted(counts)}
            self._times = (lo or 0, hi)
            self._scan = state
        return self._scan

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
                out[channel.topic] = TopicInfo(_schema_name(schema), count)
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
        if self._summary is None:
            found = self._scanned().attachments
        else:
            with self.path.open("rb") as fh:
                found = list(self._indexed(fh).iter_attachments())
        return [LogAttachment(a.name, a.media_type, a.log_time, a.data) for a in found]

    def metadata(self) -> dict[str, dict[str, str]]:
        """name → key/value pairs of every metadata record (the last wins on a repeated name)."""
        if self._summary is None:
            found = self._scanned().metadata
        else:
            if self._metadata is None:  # a few small records, asked for by several readers
                with self.path.open("rb") as fh:
                    self._metadata = list(self._indexed(fh).iter_metadata())
            found = self._metadata
        return {m.name: dict(m.metadata) for m in found}

    # ---- messages -------------------------------------------------------------------------

    def raw_messages(self, topics: Iterable[str] | None = None) -> Iterator[RawMessage]:
        """Undecoded messages in log-time order (a TruncatedLogWarning at the end if the log
        is damaged). A message's ``data`` is a read-only memoryview of its chunk
        (:mod:`flylog.io.chunks`): ``bytes(data)`` to keep it apart."""
        damage: list[str] = []
        yield from self._raw(topics, damage)
        for msg in damage:
            warnings.warn(msg, TruncatedLogWarning, stacklevel=3)

    def _raw(self, topics: Iterable[str] | None, damage: list[str]) -> Iterator[RawMessage]:
        """:meth:`raw_messages` that appends the damage report to ``damage`` instead of
        warning (warnings are process-wide: a reading thread must not issue them)."""
        wanted = None if topics is None else frozenset(topics)
        with self.path.open("rb") as fh:
            if self._summary is not None:
                found = indexed_messages(fh, self._summary, wanted)
                while True:
                    try:
                        raw = next(found)
                    except StopIteration:
                        return
                    except Exception as exc:  # a finished log damaged inside: name it
                        msg = f"{self.path}: damaged log ({type(exc).__name__}: {exc})"
                        raise LogError(msg) from None
                    yield raw
            # Here, not at import: the writer's module imports mcap's writer, which looks up
            # its package version (~25 ms of every reading command's start).
            from flylog.io.writer import MAX_WRITE_LAG_NS

            state = ScanState()
            count = 0
            for raw in in_log_time_order(scan_messages(fh, state, topics=wanted), MAX_WRITE_LAG_NS):
                count += 1
                yield raw
        if state.damage is not None:
            which = "" if wanted is None else f" on {', '.join(sorted(wanted))}"
            damage.append(
                f"{self.path}: the log is truncated or unfinished ({state.damage}); "
                f"recovered {count} intact messages{which}"
            )

    def messages(
        self, topics: Iterable[str] | None = None, *, read_ahead: int = 0
    ) -> Generator[LogMessage, None, None]:
        """Messages in log-time order, each decoded into plain values by its schema.

        With ``read_ahead`` > 0, a background thread reads, decompresses and decodes up to
        that many messages ahead of the consumer (see :mod:`flylog.io.readahead`)."""
        decode = _Decoding(self.path)
        damage: list[str] = []
        decoded: Iterator[LogMessage] = (decode(raw) for raw in self._raw(topics, damage))
        if read_ahead > 0:
            decoded = read_ahead_of(decoded, read_ahead)
        yield from decoded
        for msg in damage:
            warnings.warn(msg, TruncatedLogWarning, stacklevel=2)

    def stereo_pairs(self, *, tolerance_ns: int = 5_000_000) -> Iterator[StereoPair]:
        """The log's stereo pairs, streamed (see ``pair_stereo``)."""
        stream = self.messages([contract.LEFT_IMAGE, contract.RIGHT_IMAGE])
        for m in pair_stereo(stream, tolerance_ns=tolerance_ns):
            yield m.value


def _json_value(data: bytes | memoryview) -> Any:
    return json.loads(bytes(data))  # json reads bytes, not memoryviews


def _schema_name(schema: Schema | None) -> str:
    return "" if schema is None else schema.name


class _Decoding:
    """Decodes raw messages; one decoder per channel, built on first use."""

    def __init__(self, path: Path) -> None:
        self._path = path
        self._protobuf = DecoderFactory()
        self._decoders: dict[int, Callable[[bytes], Any]] = {}

    def _decoder(self, schema: Schema | None, channel: Channel) -> Callable[[bytes], Any]:
        parse: Callable[[bytes], Any] | None
        if channel.message_encoding == contract.JSON_MESSAGE_ENCODING:
            parse = _json_value
        else:
            parse = self._protobuf.decoder_for(channel.message_encoding, schema)
        if parse is None:
            msg = (
                f"{self._path}: topic {channel.topic} has message encoding "
                f"'{channel.message_encoding}', which flylog cannot decode"
            )
            raise LogError(msg)
        convert = DECODERS.get(_schema_name(schema))
        if convert is None:
            return parse
        if (
            convert is image
            and channel.message_encoding == contract.PROTOBUF
            and schema is not None
            and is_foxglove_raw_image(schema.data)
        ):
            return lambda data: image(raw_image_fields(data))  # pixels not copied
        return lambda data: convert(parse(data))

    def __call__(self, raw: RawMessage) -> LogMessage:
        channel, message = raw.channel, raw.message
        decoder = self._decoders.get(channel.id)
        if decoder is None:
            decoder = self._decoders[channel.id] = self._decoder(raw.schema, channel)
        try:
            value = decoder(message.data)
        except LogError as exc:
            msg = f"{self._path}: {channel.topic} at {message.log_time} ns: {exc}"
            raise LogError(msg) from None
        except Exception as exc:  # a message the schema cannot parse
            msg = (
                f"{self._path}: cannot decode the message on {channel.topic} at "
                f"{message.log_time} ns ({type(exc).__name__}: {exc})"
            )
            raise LogError(msg) from None
        return LogMessage(channel.topic, message.log_time, _schema_name(raw.schema), value)


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
