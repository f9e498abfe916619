"""The protobuf wire format (proto3), written by compiled loops for messages of hundreds of
points or poses, byte for byte as the Foxglove SDK writes them (tests/io/test_encode_bytes.py
checks it): scalar fields equal to zero are left out, sub-messages are length-delimited."""

from __future__ import annotations

import struct

import numba
import numpy as np


def _varint(value: int) -> bytes:
    out = bytearray()
    while value > 0x7F:
        out.append((value & 0x7F) | 0x80)
        value >>= 7
    out.append(value)
    return bytes(out)


def varint_field(number: int, value: int) -> bytes:
    return _varint(number << 3) + _varint(value) if value else b""


def double_field(number: int, value: float) -> bytes:
    return bytes([number << 3 | 1]) + struct.pack("<d", value) if value != 0.0 else b""


def bytes_field(number: int, payload: bytes) -> bytes:
    """A length-delimited field (sub-message), present even when empty."""
    return _varint(number << 3 | 2) + _varint(len(payload)) + payload


def _as_bytes(rows: np.ndarray) -> np.ndarray:
    """(N, k) doubles → their (N, 8k) little-endian bytes."""
    rows = np.ascontiguousarray(rows, dtype="<f8")
    return rows.view(np.uint8).reshape(len(rows), 8 * rows.shape[1])


@numba.njit(cache=True, nogil=True)
def _write_doubles(out, at, values, raw):  # pragma: no cover - compiled
    """One message whose fields 1..k are ``values``' doubles (raw: their bytes) at
    ``out[at:]``, zeros (-0.0 too) left out; returns the position after it."""
    for f in range(len(values)):
        if values[f] != 0.0:
            out[at] = (f + 1) << 3 | 1
            out[at + 1 : at + 9] = raw[8 * f : 8 * f + 8]
            at += 9
    return at


@numba.njit(cache=True, nogil=True)
def _present_bytes(values):  # pragma: no cover - compiled
    n = 0
    for v in values:
        if v != 0.0:
            n += 9
    return n


@numba.njit(cache=True, nogil=True)
def _repeated_doubles_kernel(tag, rows, raw, out):  # pragma: no cover - compiled
    at = 0
    for r in range(rows.shape[0]):
        out[at] = tag
        out[at + 1] = _present_bytes(rows[r])
        at = _write_doubles(out, at + 2, rows[r], raw[r])
    return at


@numba.njit(cache=True, nogil=True)
def _repeated_poses_kernel(tag, p, p_raw, q, q_raw, out):  # pragma: no cover - compiled
    at = 0
    for r in range(p.shape[0]):
        p_len, q_len = _present_bytes(p[r]), _present_bytes(q[r])
        out[at] = tag
        out[at + 1] = 4 + p_len + q_len
        out[at + 2] = 1 << 3 | 2
        out[at + 3] = p_len
        at = _write_doubles(out, at + 4, p[r], p_raw[r])
        out[at] = 2 << 3 | 2
        out[at + 1] = q_len
        at = _write_doubles(out, at + 2, q[r], q_raw[r])
    return at


def repeated_doubles(number: int, rows: np.ndarray) -> bytes:
    """Field ``number`` repeated: one message per row (k ≤ 14 columns, so every length is
    one byte), its fields 1..k the row's doubles; zeros (-0.0 too) are left out, as the SDK
    does, NaN is written. Written by a compiled loop that releases the GIL: the planner's
    worker encodes the overlay while the engine runs."""
    rows = np.ascontiguousarray(rows, dtype=np.float64)
    n, k = rows.shape
    if k > 14:
        msg = f"repeated_doubles writes at most 14 doubles a message, got {k}"
        raise ValueError(msg)
    out = np.empty(n * (2 + 9 * k), dtype=np.uint8)
    end = _repeated_doubles_kernel(number << 3 | 2, rows, _as_bytes(rows), out)
    return out[:end].tobytes()


def repeated_poses(number: int, position: np.ndarray, orientation: np.ndarray) -> bytes:
    """Field ``number`` repeated: one Pose per row, position (N, 3) and orientation (N, 4)."""
    p = np.ascontiguousarray(position, dtype=np.float64)
    q = np.ascontiguousarray(orientation, dtype=np.float64)
    if p.shape[1:] != (3,) or q.shape != (len(p), 4):
        msg = f"repeated_poses needs (N, 3) and (N, 4), got {p.shape} and {q.shape}"
        raise ValueError(msg)
    out = np.empty(len(p) * (6 + 9 * 7), dtype=np.uint8)
    end = _repeated_poses_kernel(number << 3 | 2, p, _as_bytes(p), q, _as_bytes(q), out)
    return out[:end].tobytes()
