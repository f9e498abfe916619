"""Plain-numpy reference of the compiled repeated-field writers of flylog.io.protobuf_wire."""

from __future__ import annotations

import numpy as np


def _doubles_messages(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each row of ``rows`` (N, k ≤ 14), a message whose fields 1..k are its doubles:
    the (N, 9k) bytes with every field, which bytes to keep (fields equal to zero, -0.0 too,
    are left out, as the SDK does; NaN is written), and each message's length."""
    n, k = rows.shape
    record = np.empty((n, k, 9), dtype=np.uint8)
    record[:, :, 0] = np.arange(1, k + 1) << 3 | 1
    record[:, :, 1:] = np.ascontiguousarray(rows, dtype="<f8").view(np.uint8).reshape(n, k, 8)
    present = rows != 0.0
    return record.reshape(n, 9 * k), np.repeat(present, 9, axis=1), 9 * present.sum(axis=1)


def _kept(parts: list[tuple[np.ndarray, np.ndarray | None]]) -> bytes:
    """The rows of the parts side by side, row after row, without the bytes not kept
    (``None``: all kept)."""
    record = np.hstack([p for p, _ in parts])
    keep = np.hstack([np.ones(p.shape, bool) if k is None else k for p, k in parts])
    return record[keep].tobytes()


def _heads(*columns: int | np.ndarray, n: int) -> np.ndarray:
    """(n, len(columns)) bytes: tags and one-byte lengths (every length here is < 128)."""
    out = np.empty((n, len(columns)), dtype=np.uint8)
    for i, column in enumerate(columns):
        out[:, i] = column
    return out


def repeated_doubles(number: int, rows: np.ndarray) -> bytes:
    """Field ``number`` repeated: one message per row, its fields 1..k the row's doubles."""
    body, keep, length = _doubles_messages(rows)
    return _kept([(_heads(number << 3 | 2, length, n=len(rows)), None), (body, keep)])


def repeated_poses(number: int, position: np.ndarray, orientation: np.ndarray) -> bytes:
    """Field ``number`` repeated: one Pose per row, position (N, 3) and orientation (N, 4)."""
    p_body, p_keep, p_len = _doubles_messages(position)
    q_body, q_keep, q_len = _doubles_messages(orientation)
    n = len(position)
    return _kept(
        [
            (_heads(number << 3 | 2, 4 + p_len + q_len, 1 << 3 | 2, p_len, n=n), None),
            (p_body, p_keep),
            (_heads(2 << 3 | 2, q_len, n=n), None),
            (q_body, q_keep),
        ]
    )
