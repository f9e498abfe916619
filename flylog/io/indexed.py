"""Attachments and metadata records of a finished log, read where its summary indexes
them and checked: the record's opcode, length and name must be the index's, an
attachment's CRC must match. A record that fails is skipped and named (the caller warns).
"""

from __future__ import annotations

import io
import struct
from collections.abc import Callable, Iterable
from typing import IO, Any, TypeVar

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Attachment, Metadata
from mcap.summary import Summary

from flylog.io.scan import checked_attachment

_RECORD = struct.Struct("<BQ")


def _record_at(fh: IO[bytes], offset: int, length: int, opcode: int) -> bytes:
    """The body of the record of ``opcode`` an index places at ``offset``, ``length`` long."""
    fh.seek(offset)
    record = fh.read(length)
    if len(record) < _RECORD.size:
        msg = "it lies past the end of the file"
        raise ValueError(msg)
    found, body_length = _RECORD.unpack_from(record)
    if found != opcode or _RECORD.size + body_length != len(record):
        msg = f"the index points at a record of opcode {found:#04x}, {len(record)} bytes"
        raise ValueError(msg)
    return record[_RECORD.size :]


R = TypeVar("R", Attachment, Metadata)


def _indexed(
    fh: IO[bytes],
    indexes: Iterable[Any],
    shift: int,
    opcode: int,
    parse: Callable[[bytes], R],
) -> tuple[list[R], list[str]]:
    """The records ``indexes`` place (each where its index says or ``shift`` bytes further:
    the first that ``parse`` accepts and that carries its index's name), and a description
    of each one skipped."""
    found: list[R] = []
    skipped: list[str] = []
    for index in indexes:
        failure: Exception | None = None
        for offset in (index.offset, index.offset + shift) if shift else (index.offset,):
            try:
                record = parse(_record_at(fh, offset, index.length, opcode))
                if record.name != index.name:
                    msg = f"it is named '{record.name}'"
                    raise ValueError(msg)
            except Exception as exc:  # tried further, or skipped and named
                failure = failure or exc
                continue
            found.append(record)
            break
        else:
            skipped.append(f"'{index.name}' at byte {index.offset} ({failure})")
    return found, skipped


def indexed_attachments(
    fh: IO[bytes], summary: Summary, shift: int = 0, *, require_crcs: bool = True
) -> tuple[list[Attachment], list[str]]:
    """The attachments the summary indexes, each where its index says or ``shift`` bytes
    further (the first that passes its checks), and a description of each one skipped."""
    return _indexed(
        fh,
        summary.attachment_indexes,
        shift,
        Opcode.ATTACHMENT,
        lambda body: checked_attachment(body, require_crc=require_crcs),
    )


def indexed_metadata(
    fh: IO[bytes], summary: Summary, shift: int = 0
) -> tuple[list[Metadata], list[str]]:
    """The metadata records the summary indexes, each where its index says or ``shift``
    bytes further (the first that parses with its index's name), and a description of each
    one skipped. MCAP gives them no CRC: a record is skipped only when it cannot be parsed."""
    return _indexed(
        fh,
        summary.metadata_indexes,
        shift,
        Opcode.METADATA,
        lambda body: Metadata.read(ReadDataStream(io.BytesIO(body))),
    )
