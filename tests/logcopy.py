"""Copying a log for tests and benchmarks: some of its topics, records and attachments."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from mcap.writer import Writer

from flylog.io.reader import open_log

Metadata = dict[str, dict[str, str]]


def copy_log(
    source: Path,
    target: Path,
    *,
    topics: Callable[[str], bool] = lambda topic: True,
    metadata: Callable[[Metadata], Metadata] = lambda records: records,
    attachments: bool = True,
    chunk_size: int = 1 << 20,
) -> Path:
    """``target``: the messages of ``source`` on the topics ``topics`` accepts, byte for byte,
    its metadata records as ``metadata`` returns them (to edit or drop some), and its
    attachments unless told not to."""
    reader = open_log(source)
    with target.open("wb") as fh:
        writer = Writer(fh, chunk_size=chunk_size, use_summary_offsets=False)
        writer.start()
        for name, values in metadata(reader.metadata()).items():
            writer.add_metadata(name, values)
        for a in reader.attachments() if attachments else ():
            writer.add_attachment(0, a.log_time_ns, a.name, a.media_type, a.data)
        schemas: dict[str, int] = {}
        channels: dict[str, int] = {}
        for raw in reader.raw_messages():
            topic, s = raw.channel.topic, raw.schema
            if not topics(topic):
                continue
            if s.name not in schemas:
                schemas[s.name] = writer.register_schema(s.name, s.encoding, s.data)
            if topic not in channels:
                channels[topic] = writer.register_channel(
                    topic, raw.channel.message_encoding, schemas[s.name]
                )
            m = raw.message
            writer.add_message(channels[topic], m.log_time, m.data, m.publish_time, m.sequence)
        writer.finish()
    return target
