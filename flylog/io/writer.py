"""Atomic MCAP writing: ``with LogWriter(path) as log: log.write(topic, t_ns, message)``.

The log is written to a temporary file next to ``path`` and renamed onto ``path`` only when
the ``with`` block ends normally; on any exception (KeyboardInterrupt included) the
temporary file is removed and ``path`` is left as it was. A writer killed outright leaves
that temporary ``.<name>.*.part`` file behind: an unfinished log the reader recovers.
"""

from __future__ import annotations

import enum
import json
import os
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import IO, Any

from mcap.writer import CompressionType, Writer

import flylog
from flylog.config import param
from flylog.errors import LogError
from flylog.io import contract
from flylog.io.atomic import Batch, publish, temporary_beside


class Compression(enum.Enum):
    ZSTD = "zstd"
    LZ4 = "lz4"
    NONE = "none"


_MCAP_COMPRESSION = {
    Compression.ZSTD: CompressionType.ZSTD,
    Compression.LZ4: CompressionType.LZ4,
    Compression.NONE: CompressionType.NONE,
}

# How far behind the newest message already written a message's log time may lie. Logs
# honouring it read back in exact log-time order even when unfinished (the recovery path
# merges through a buffer of this many nanoseconds; see flylog.io.scan).
MAX_WRITE_LAG_NS = 1_000_000_000


@dataclass(frozen=True)
class LogConfig:
    """How logs are written."""

    # zstd: a sensor log is kept and replayed many times, written once. The corridor at
    # 640×480, 6 s (tests/benchmarks/bench_compression.py, docs/performance.md): 160 MiB raw,
    # 79 MiB with lz4, 43 MiB with zstd (level 3, mcap's); writing costs 1.15 s of CPU with
    # zstd against 0.63 s with lz4 (~6 ms more a stereo pair, simulate's ~30 pairs/s on one
    # core become ~25), reading 0.31 s against 0.18 s, 0.5 % of the log's replay.
    compression: Compression = param(
        Compression.ZSTD,
        help="chunk compression: zstd (0.55× lz4's size), lz4 (1.8× less CPU to write) or none",
    )
    chunk_size: int = param(
        4 * 1024 * 1024,
        help="uncompressed bytes per chunk (bounds the memory of writing and reading)",
        unit="B",
        min=4096,
        max=256 * 1024 * 1024,
    )


_DEFAULTS = LogConfig()


class LogWriter:
    """Writes one MCAP log atomically; registers each topic's schema and channel lazily."""

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        compression: Compression | str = _DEFAULTS.compression,
        chunk_size: int = _DEFAULTS.chunk_size,
        batch: Batch | None = None,
    ) -> None:
        """``batch``: published with the batch's other outputs (:class:`Batch`), not at the
        ``with`` block's end."""
        self.path = Path(path)
        self._batch = batch
        self._compression = Compression(compression)
        self._chunk_size = int(chunk_size)
        self._tmp: Path | None = None
        self._fh: IO[bytes] | None = None
        self._writer: Writer | None = None
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, tuple[int, str]] = {}  # topic → (channel id, schema name)
        self._last_time: dict[str, int] = {}
        self._sequence: dict[str, int] = {}
        self._newest_ns = 0

    @classmethod
    def from_config(cls, path: str | os.PathLike[str], config: LogConfig) -> LogWriter:
        return cls(path, compression=config.compression, chunk_size=config.chunk_size)

    def __enter__(self) -> LogWriter:
        fd, self._tmp = temporary_beside(self.path)
        self._fh = os.fdopen(fd, "wb")
        self._writer = Writer(
            self._fh,
            chunk_size=self._chunk_size,
            compression=_MCAP_COMPRESSION[self._compression],
            # mcap-python writes empty summary-offset groups (no attachments, say), which
            # `mcap doctor` reports as errors; readers find the summary without offsets.
            use_summary_offsets=False,
        )
        library = f"flylog/{flylog.__version__}{contract.METADATA_CRC_MARK}"
        self._writer.start(profile="", library=library)
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        assert self._writer is not None and self._fh is not None and self._tmp is not None
        try:
            if exc_type is None:
                self._writer.finish()
                self._fh.flush()
                os.fsync(self._fh.fileno())
                self._fh.close()
                publish(self._tmp, self.path, self._batch)
                self._tmp = None  # renamed, or the batch's now
        finally:
            if not self._fh.closed:
                self._fh.close()
            if self._tmp is not None:
                self._tmp.unlink(missing_ok=True)
            self._writer = None

    def _live(self) -> Writer:
        if self._writer is None:
            msg = f"log {self.path} is not open: use LogWriter inside a `with` block"
            raise LogError(msg)
        return self._writer

    def _channel(self, topic: str, message: Any) -> tuple[int, str]:
        """The channel of ``topic``, registering it (and its schema) on first use."""
        found = self._channels.get(topic)
        if found is None:
            schema_name = _schema_of(topic, message)
            writer = self._live()
            schema_id = self._schemas.get(schema_name)
            if schema_id is None:
                schema_id = writer.register_schema(*contract.schema_record(schema_name))
                self._schemas[schema_name] = schema_id
            channel_id = writer.register_channel(
                topic, contract.message_encoding(schema_name), schema_id
            )
            found = self._channels[topic] = (channel_id, schema_name)
        return found

    def write(self, topic: str, log_time_ns: int, message: Any) -> None:
        """Write a Foxglove message (protobuf topics) or a dict (JSON topics) at a log time.

        Log times must not decrease on a topic, nor lie more than MAX_WRITE_LAG_NS behind
        the newest log time written on any topic."""
        channel_id, schema_name = self._channel(topic, message)
        if isinstance(message, dict):
            if schema_name not in contract.JSON_SCHEMAS:
                msg = f"topic {topic} carries {schema_name} messages, not a dict"
                raise LogError(msg)
            try:
                data = json.dumps(message, allow_nan=False, separators=(",", ":")).encode()
            except (TypeError, ValueError) as exc:
                msg = f"{topic}: message cannot be written as JSON ({exc})"
                raise LogError(msg) from None
        else:
            get_schema = getattr(type(message), "get_schema", None)
            found = type(message).__name__ if get_schema is None else get_schema().name
            if found != schema_name:
                msg = f"topic {topic} carries {schema_name} messages, got a {found}"
                raise LogError(msg)
            data = message.encode()
        t = int(log_time_ns)
        if t < self._last_time.get(topic, 0):
            msg = f"{topic}: log time {t} ns is before the previous one {self._last_time[topic]}"
            raise LogError(msg)
        if t < self._newest_ns - MAX_WRITE_LAG_NS:
            msg = (
                f"{topic}: log time {t} ns lies more than {MAX_WRITE_LAG_NS} ns behind the "
                f"newest message written ({self._newest_ns} ns)"
            )
            raise LogError(msg)
        self._last_time[topic] = t
        self._newest_ns = max(self._newest_ns, t)
        sequence = self._sequence.get(topic, 0) + 1
        self._sequence[topic] = sequence
        self._live().add_message(channel_id, t, data, t, sequence)

    def attach(self, name: str, data: bytes, media_type: str, *, log_time_ns: int = 0) -> None:
        """Store a file (the scene file, say) in the log."""
        self._live().add_attachment(
            create_time=0, log_time=int(log_time_ns), name=name, media_type=media_type, data=data
        )

    def add_metadata(self, name: str, values: dict[str, str]) -> None:
        bad = {k: v for k, v in values.items() if not (isinstance(k, str) and isinstance(v, str))}
        if bad:
            msg = f"metadata '{name}' must map strings to strings; got {bad!r}"
            raise LogError(msg)
        checked = {k: v for k, v in values.items() if k != contract.METADATA_CRC_KEY}
        checked[contract.METADATA_CRC_KEY] = contract.metadata_crc(name, checked)
        self._live().add_metadata(name, checked)


def _schema_of(topic: str, message: Any) -> str:
    """The schema a topic carries: the contract's, else the Foxglove message's own."""
    if topic in contract.TOPIC_SCHEMAS:
        return contract.TOPIC_SCHEMAS[topic]
    if isinstance(message, dict):
        msg = f"topic {topic} is not in the flylog contract: no JSON schema for its dicts"
        raise LogError(msg)
    get_schema = getattr(type(message), "get_schema", None)
    if get_schema is None:
        msg = f"cannot write a {type(message).__name__} to {topic}: not a Foxglove message"
        raise LogError(msg)
    name = get_schema().name
    if name not in contract.FOXGLOVE_TYPES:
        msg = f"cannot write {name} to {topic}: only the contract's schemas are supported"
        raise LogError(msg)
    return name
