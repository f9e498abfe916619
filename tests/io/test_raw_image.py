"""Images parsed without copying their pixels: the same arrays as protobuf's parser gives,
only for Foxglove's RawImage schema, and errors for damaged messages."""

from __future__ import annotations

import foxglove.messages as fm
import numpy as np
import pytest
from google.protobuf import descriptor_pb2
from mcap.records import Schema
from mcap_protobuf.decoder import DecoderFactory

from flylog.errors import LogError
from flylog.io import contract, encode
from flylog.io.decode import image, is_foxglove_raw_image, raw_image_fields


def _schema() -> Schema:
    name, encoding, data = contract.schema_record(contract.RAW_IMAGE)
    return Schema(id=1, name=name, encoding=encoding, data=data)


def _protobuf_image(data: bytes) -> np.ndarray:
    return image(DecoderFactory().decoder_for(contract.PROTOBUF, _schema())(data))


def _messages() -> list[bytes]:
    rng = np.random.default_rng(3)
    rgb = rng.integers(0, 256, (5, 7, 3), dtype=np.uint8)
    mono = rng.integers(0, 256, (4, 6), dtype=np.uint8)
    bgr = fm.RawImage(
        timestamp=encode.timestamp(12),
        frame_id="cam",
        width=3,
        height=2,
        encoding="bgr8",
        step=11,
        data=bytes(range(22)),
    )
    return [
        encode.raw_image(rgb, 1_000_000_123, "camera_left").encode(),
        encode.raw_image(mono, 5, "").encode(),
        bgr.encode(),  # padded rows (step > 3·width), stored blue first
        fm.RawImage(width=0, height=0, encoding="mono8", step=0).encode(),  # defaults omitted
    ]


@pytest.mark.parametrize("k", range(4))
def test_pixels_are_protobufs_as_a_view_of_the_message(k):
    data = _messages()[k]
    ours, theirs = image(raw_image_fields(data)), _protobuf_image(data)
    assert ours.shape == theirs.shape and ours.strides == theirs.strides
    assert np.array_equal(ours, theirs)
    assert not ours.flags.writeable
    if ours.size:
        assert np.shares_memory(ours, np.frombuffer(data, dtype=np.uint8))


def test_the_foxglove_schema_is_recognised_and_a_renumbered_one_is_not():
    assert is_foxglove_raw_image(_schema().data)
    files = descriptor_pb2.FileDescriptorSet.FromString(_schema().data)
    for f in files.file:
        for m in f.message_type:
            if m.name == "RawImage":
                for field in m.field:
                    if field.name == "data":
                        field.number = 16
    assert not is_foxglove_raw_image(files.SerializeToString())
    assert not is_foxglove_raw_image(b"not a descriptor set")


def test_a_message_cut_short_is_a_log_error():
    data = _messages()[0]
    for cut in (len(data) - 1, len(data) // 2, 3):
        with pytest.raises(LogError, match="cut"):
            raw_image_fields(data[:cut])
