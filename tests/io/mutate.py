"""Seeded damage to a file's bytes, independent of any MCAP library: byte flips, cuts,
inserted and deleted spans, and deleted or duplicated records (found by walking the
file's ``opcode, u64 length`` record headers from byte 8, as the MCAP format lays them).
"""

from __future__ import annotations

import struct

import numpy as np

MUTATIONS = ("flip", "truncate", "insert", "delete", "delete_record", "duplicate_record")
_HEADER = struct.Struct("<BQ")
_MAGIC_SIZE = 8


def record_spans(data: bytes) -> list[tuple[int, int]]:
    """(start, end) of each record between the leading and trailing magic, as far as the
    lengths in their headers lead."""
    spans = []
    at = _MAGIC_SIZE
    while at + _HEADER.size <= len(data) - _MAGIC_SIZE:
        _, length = _HEADER.unpack_from(data, at)
        end = at + _HEADER.size + length
        if end > len(data):
            break
        spans.append((at, end))
        at = end
    return spans


def _position(data: bytes, spans: list[tuple[int, int]], rng: np.random.Generator) -> int:
    """A byte of ``data``: half the time anywhere, half the time among the first 48 bytes
    of a record (its header and first fields: lengths, times, offsets, names), where a
    uniform choice rarely falls in a file made mostly of chunk payloads."""
    if spans and rng.random() < 0.5:
        start, end = spans[int(rng.integers(len(spans)))]
        return int(rng.integers(start, min(end, start + 48)))
    return int(rng.integers(0, len(data)))


def mutate(data: bytes, rng: np.random.Generator) -> tuple[bytes, str]:
    """One damaged copy of ``data`` and a description of the damage."""
    kind = MUTATIONS[int(rng.integers(len(MUTATIONS)))]
    spans = record_spans(data)
    if kind == "flip":
        out = bytearray(data)
        where = sorted(_position(data, spans, rng) for _ in range(int(rng.integers(1, 5))))
        for i in where:
            out[i] ^= int(rng.integers(1, 256))
        return bytes(out), f"flip at {where}"
    if kind == "truncate":
        cut = _position(data, spans, rng)
        return data[:cut], f"truncate at {cut}"
    if kind == "insert":
        at = _position(data, spans, rng)
        span = rng.integers(0, 256, int(rng.integers(1, 65)), dtype=np.uint8).tobytes()
        return data[:at] + span + data[at:], f"insert {len(span)} bytes at {at}"
    if kind == "delete":
        at = _position(data, spans, rng)
        size = int(rng.integers(1, 65))
        return data[:at] + data[at + size :], f"delete {size} bytes at {at}"
    start, end = spans[int(rng.integers(len(spans)))]
    opcode = data[start]
    if kind == "delete_record":
        return data[:start] + data[end:], f"delete record {opcode:#04x} at {start}"
    return data[:end] + data[start:end] + data[end:], f"duplicate record {opcode:#04x} at {start}"


_CHUNK, _MESSAGE_INDEX = 0x06, 0x07


def delete_chunks(data: bytes, rng: np.random.Generator) -> tuple[bytes, str]:
    """``data`` with one to three of its chunks deleted whole, each with the message index
    records that follow it half the time (as a lost or cut-out span of a multi-chunk log)."""
    spans = record_spans(data)
    chunks = [k for k, (a, _) in enumerate(spans) if data[a] == _CHUNK]
    count = min(len(chunks), int(rng.integers(1, 4)))
    picked = sorted(int(i) for i in rng.choice(len(chunks), size=count, replace=False))
    cuts = []
    for i in picked:
        k = chunks[i]
        start, end = spans[k]
        if rng.random() < 0.5:
            while k + 1 < len(spans) and data[spans[k + 1][0]] == _MESSAGE_INDEX:
                k += 1
                end = spans[k][1]
        cuts.append((start, end))
    out = bytearray()
    at = 0
    for start, end in cuts:
        out += data[at:start]
        at = end
    out += data[at:]
    return bytes(out), f"delete chunks {picked} of {len(chunks)}"
