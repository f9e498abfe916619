"""ROS 2 message types flylog reads and writes, and CDR decoding with ``rosbags``.

Each bag's messages are decoded with the types its own ``ros2msg`` schemas define (so a
``sensor_msgs/msg/Range`` of any distribution decodes as recorded); a channel without a
schema falls back to the standard definitions (``STANDARD_STORE``).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from mcap.records import Channel, Message, Schema
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from flylog.errors import LogError

IMAGE = "sensor_msgs/msg/Image"
COMPRESSED_IMAGE = "sensor_msgs/msg/CompressedImage"
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"
RANGE = "sensor_msgs/msg/Range"
ODOMETRY = "nav_msgs/msg/Odometry"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
IMAGE_TYPES = (IMAGE, COMPRESSED_IMAGE)

TF = "/tf"
TF_STATIC = "/tf_static"

# The definitions written by the exporter and used for channels without a schema.
STANDARD_STORE = Stores.ROS2_HUMBLE
CDR = "cdr"
ROS2MSG = "ros2msg"


def standard_typestore() -> Typestore:
    return get_typestore(STANDARD_STORE)


class CdrDecoder:
    """CDR → rosbags message objects, one decoding function per distinct schema."""

    def __init__(self, bag: Path) -> None:
        self._bag = bag
        self._by_schema: dict[tuple[str, bytes], Callable[[bytes | memoryview], Any]] = {}
        self._standard: Typestore | None = None

    def _function(
        self, topic: str, schema: Schema | None, channel: Channel
    ) -> Callable[[bytes | memoryview], Any]:
        if channel.message_encoding != CDR:
            msg = (
                f"{self._bag}: topic {topic} has message encoding "
                f"'{channel.message_encoding}'; a ROS 2 bag's messages are CDR"
            )
            raise LogError(msg)
        if schema is None or not schema.data:
            if self._standard is None:
                self._standard = standard_typestore()
            store, name = self._standard, (schema.name if schema else "")
            if name not in store.types:
                msg = f"{self._bag}: topic {topic} has no schema and no standard type '{name}'"
                raise LogError(msg)
        elif schema.encoding != ROS2MSG:
            msg = (
                f"{self._bag}: topic {topic} has a '{schema.encoding}' schema; flylog reads "
                f"'{ROS2MSG}' schemas only (record with the default message definitions)"
            )
            raise LogError(msg)
        else:
            name = schema.name
            store = get_typestore(Stores.EMPTY)
            try:
                store.register(get_types_from_msg(schema.data.decode(), name))
            except Exception as exc:
                msg = f"{self._bag}: the schema of {topic} ({name}) does not parse ({exc})"
                raise LogError(msg) from None

        def decode(data: bytes | memoryview) -> Any:
            return store.deserialize_cdr(data, name)

        return decode

    def decode(self, topic: str, schema: Schema | None, message: Message, channel: Channel) -> Any:
        key = (topic if schema is None else schema.name, b"" if schema is None else schema.data)
        function = self._by_schema.get(key)
        if function is None:
            function = self._by_schema[key] = self._function(topic, schema, channel)
        try:
            return function(message.data)
        except Exception as exc:  # damaged CDR: the bytes do not fit the type
            msg = (
                f"{self._bag}: the message on {topic} at {message.log_time} ns is damaged "
                f"(its CDR does not decode as {key[0]}: {type(exc).__name__}: {exc})"
            )
            raise LogError(msg) from None
