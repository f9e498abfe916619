"""The one way flylog writes a rosbag2 directory: rosbags' ``Writer`` (metadata.yaml,
connections, CDR) over an MCAP storage written by the ``mcap`` library, so that every
chunk carries its CRC and is zstd-compressed, as ``ros2 bag record`` writes by default
(rosbag2's MCAP storage: zstd chunks with CRCs). rosbags' own MCAP storage writes neither a
chunk CRC nor a summary CRC (0 in both fields): a damaged bag it wrote reads as another bag.

:func:`open_bag_writer` is what every bag flylog writes goes through (``flylog export
--ros2`` and any other export): its settings live here once.
"""

from __future__ import annotations

import os
from pathlib import Path
from types import MappingProxyType
from typing import IO, Any

import flylog
from flylog.io import contract

# Uncompressed bytes per chunk: mcap's default, and what rosbags' own storage uses (1 MiB).
BAG_CHUNK_SIZE = 1 << 20
# The rosbag2 metadata record that MCAP storage holds (metadata.yaml's content).
ROSBAG2_METADATA = "rosbag2"


class _CheckedMcapStorage:
    """rosbags' StorageWriter protocol over ``mcap``'s writer: chunk and summary CRCs, and
    zstd chunks when the bag's compression mode is ``storage``."""

    def __init__(self, path: Path, compression: Any) -> None:
        from mcap.writer import CompressionType, Writer
        from rosbags.rosbag2 import CompressionMode

        self.path = path / f"{path.name}.mcap"
        self._fh: IO[bytes] = self.path.open("xb")
        compressed = compression == CompressionMode.STORAGE
        self._writer = Writer(
            self._fh,
            chunk_size=BAG_CHUNK_SIZE,
            compression=CompressionType.ZSTD if compressed else CompressionType.NONE,
            enable_crcs=True,
            use_summary_offsets=False,  # mcap-python's empty groups: see flylog.io.writer
        )
        library = f"flylog/{flylog.__version__}{contract.METADATA_CRC_MARK}"
        self._writer.start(profile="ros2", library=library)
        self._schemas: dict[str, int] = {}
        self._channels: dict[int, int] = {}  # rosbags connection id → MCAP channel id

    def add_msgtype(self, connection: Any) -> None:
        from rosbags.interfaces import MessageDefinitionFormat

        if connection.msgtype in self._schemas:
            return
        msg_format = connection.msgdef.format == MessageDefinitionFormat.MSG
        encoding = "ros2msg" if msg_format else "ros2idl"
        self._schemas[connection.msgtype] = self._writer.register_schema(
            connection.msgtype, encoding, connection.msgdef.data.encode("utf-8")
        )

    def add_connection(self, connection: Any, offered_qos_profiles: str) -> None:
        self._channels[connection.id] = self._writer.register_channel(
            connection.topic,
            connection.ext.serialization_format,
            self._schemas[connection.msgtype],
            {"offered_qos_profiles": offered_qos_profiles},
        )

    def write(self, connection: Any, timestamp: int, data: bytes | memoryview) -> None:
        self._writer.add_message(self._channels[connection.id], timestamp, bytes(data), timestamp)

    def close(self, version: int, metadata: str) -> None:
        values = {"serialized_metadata": metadata}
        values[contract.METADATA_CRC_KEY] = contract.metadata_crc(ROSBAG2_METADATA, values)
        self._writer.add_metadata(ROSBAG2_METADATA, values)
        self._writer.finish()
        self._fh.flush()
        os.fsync(self._fh.fileno())
        self._fh.close()

    def abort(self) -> None:
        self._fh.close()


def open_bag_writer(path: Path) -> Any:
    """A rosbags ``Writer`` (not yet opened: ``with writer:``) of a new rosbag2 directory at
    ``path``: MCAP storage, zstd chunks with CRCs, metadata.yaml version 9."""
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer

    class _Writer(Writer):  # type: ignore[misc]
        STORAGE_PLUGINS = MappingProxyType(
            {**Writer.STORAGE_PLUGINS, StoragePlugin.MCAP: _CheckedMcapStorage}
        )

    writer = _Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    return writer
