"""From a raw MCAP message to a :class:`~flylog.io.records.LogMessage`: the channel's
decoder (protobuf by the schema the log carries, or JSON), then :mod:`flylog.io.decode`'s
conversion to plain values; a message that cannot be decoded is a LogError naming the file,
the topic and the time."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mcap.records import Channel, Schema
from mcap_protobuf.decoder import DecoderFactory

from flylog.errors import LogError
from flylog.io import contract
from flylog.io.chunks import RawMessage
from flylog.io.decode import DECODERS, image, is_foxglove_raw_image, raw_image_fields
from flylog.io.records import LogMessage


def _json_value(data: bytes | memoryview) -> Any:
    return json.loads(bytes(data))  # json reads bytes, not memoryviews


def schema_name(schema: Schema | None) -> str:
    """A schema's name; "" for a message without a schema."""
    return "" if schema is None else schema.name


class Decoding:
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
        convert = DECODERS.get(schema_name(schema))
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
        try:
            if decoder is None:
                decoder = self._decoders[channel.id] = self._decoder(raw.schema, channel)
            value = decoder(message.data)
        except LogError as exc:
            msg = f"{self._path}: {channel.topic} at {message.log_time} ns: {exc}"
            raise LogError(msg) from None
        except Exception as exc:  # a message (or a schema) that cannot be parsed
            msg = (
                f"{self._path}: cannot decode the message on {channel.topic} at "
                f"{message.log_time} ns ({type(exc).__name__}: {exc})"
            )
            raise LogError(msg) from None
        return LogMessage(channel.topic, message.log_time, schema_name(raw.schema), value)
