"""Bags written by ``flylog export --ros2`` carry chunk and summary CRCs and zstd chunks (as
``ros2 bag record`` writes), so that a damaged export is read with a warning, never as
another bag; their rosbag2 metadata record carries flylog's checksum."""

from __future__ import annotations

import struct
import warnings

import pytest
from mcap.reader import make_reader

from flylog.io import DamagedLogWarning, contract
from flylog.io.scan import messages_lost
from flylog.ros2.bag import open_bag
from flylog.ros2.export import export_ros2
from tests.io.mutate import record_spans

from .test_equivalence import CORRIDOR

CHUNK = 0x06


@pytest.fixture(scope="module")
def bag(tmp_path_factory):
    return export_ros2(CORRIDOR, tmp_path_factory.mktemp("export") / "bag").output


def test_chunks_are_zstd_with_crcs_and_the_summary_has_its_crc(bag):
    data = (bag / "bag.mcap").read_bytes()
    summary = make_reader((bag / "bag.mcap").open("rb")).get_summary()
    assert summary is not None and len(summary.chunk_indexes) >= 2
    assert {c.compression for c in summary.chunk_indexes} == {"zstd"}
    for start, _ in record_spans(data):
        if data[start] == CHUNK:
            assert struct.unpack_from("<I", data, start + 9 + 24)[0] != 0  # the chunk's CRC
    assert struct.unpack_from("<I", data, len(data) - 12)[0] != 0  # the summary CRC
    assert b"ros2" in data[:64] and contract.METADATA_CRC_MARK.encode() in data[:128]
    assert "serialized_metadata" in open_bag(bag)._readers[0].metadata()["rosbag2"]


def test_a_flipped_byte_in_a_chunk_is_a_counted_loss(bag, tmp_path):
    data = bytearray((bag / "bag.mcap").read_bytes())
    start = next(a for a, _ in record_spans(bytes(data)) if data[a] == CHUNK)
    data[start + 200] ^= 0x40  # inside the compressed messages
    copy = tmp_path / "bag"
    copy.mkdir()
    (copy / "bag.mcap").write_bytes(bytes(data))
    (copy / "metadata.yaml").write_bytes((bag / "metadata.yaml").read_bytes())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        read = sum(1 for _ in open_bag(copy).messages())
    whole = sum(1 for _ in open_bag(bag).messages())
    lost, exact = messages_lost(w.message for w in caught)
    assert read < whole and (lost, exact) == (whole - read, True)
    assert any(isinstance(w.message, DamagedLogWarning) for w in caught)
