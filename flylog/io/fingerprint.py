"""A log's fingerprint: a short content-based name that tells two logs apart, cheap enough
to compute for every run (replay stores the fingerprint of the log it read in the run's
metadata; ``flylog metrics`` refuses a run scored against another log).

A finished log with an intact summary (:mod:`flylog.io.summary`) is fingerprinted from
what its writer already checksummed: the summary section (schemas, channels, statistics,
every chunk's index), the CRC of every chunk's uncompressed records, the CRC of every
attachment, and the metadata records (MCAP gives them no CRC; they are small). That reads
a few kilobytes whatever the log's size: 6 ms for a 653 MB, 60 s log at 640×480, 0.0006 of
the 10.9 s of decoding its messages, where a streamed hash of the file takes 5.8 s, 0.53 of
it (docs/log-integrity.md; ``tests/benchmarks/bench_fingerprint.py`` measures both ratios).
Any other log (no summary, a damaged one, chunks without CRCs) is fingerprinted by that
streamed hash. The two kinds are named apart (``summary:`` and ``file:``): a log that loses its
summary gets another fingerprint, as a log with other content does. A rosbag2 directory's
fingerprint (``dir:``) combines the names and fingerprints of the files it holds.
"""

from __future__ import annotations

import hashlib
import os
import struct
from pathlib import Path
from typing import IO

from flylog.errors import LogError
from flylog.io.inputs import open_input
from flylog.io.summary import read_checked_summary

_RECORD = struct.Struct("<BQ")
_CHUNK_CRC = struct.Struct("<QQQI")  # start, end, uncompressed size, uncompressed CRC
_ATTACHMENT_CRC = 4
_STREAM_BLOCK = 1 << 20
DIGEST_BYTES = 16


def log_fingerprint(path: str | os.PathLike[str]) -> str:
    """The fingerprint of the log at ``path`` (see the module's docstring); LogError if it
    cannot be read."""
    path = Path(path)
    if path.is_dir():
        return _directory_fingerprint(path)
    try:
        with open_input(path, "the log") as fh:
            return _summary_fingerprint(fh) or _file_fingerprint(fh)
    except OSError as exc:
        msg = f"{path}: cannot be read to fingerprint it ({exc.strerror})"
        raise LogError(msg) from None


def _directory_fingerprint(path: Path) -> str:
    h = hashlib.blake2b(digest_size=DIGEST_BYTES)
    for file in sorted(f for f in path.iterdir() if f.is_file()):
        h.update(file.name.encode() + b"\0" + log_fingerprint(file).encode() + b"\0")
    return f"dir:{h.hexdigest()}"


def _summary_fingerprint(fh: IO[bytes]) -> str | None:
    checked = read_checked_summary(fh)
    summary = checked.summary
    if summary is None or checked.crc == 0:
        return None
    h = hashlib.blake2b(digest_size=DIGEST_BYTES)
    fh.seek(checked.start)
    h.update(fh.read(fh.seek(0, os.SEEK_END) - checked.start))  # summary, footer, magic
    for index in summary.chunk_indexes:
        fh.seek(index.chunk_start_offset + _RECORD.size)
        head = fh.read(_CHUNK_CRC.size)
        if len(head) < _CHUNK_CRC.size or _CHUNK_CRC.unpack(head)[3] == 0:
            return None  # a chunk without its CRC: only the bytes say what it holds
        h.update(head)
    for attachment in summary.attachment_indexes:
        fh.seek(attachment.offset + attachment.length - _ATTACHMENT_CRC)
        h.update(fh.read(_ATTACHMENT_CRC))
    for metadata in summary.metadata_indexes:
        fh.seek(metadata.offset)
        h.update(fh.read(metadata.length))
    return f"summary:{h.hexdigest()}"


def _file_fingerprint(fh: IO[bytes]) -> str:
    h = hashlib.blake2b(digest_size=DIGEST_BYTES)
    fh.seek(0)
    while block := fh.read(_STREAM_BLOCK):
        h.update(block)
    return f"file:{h.hexdigest()}"
