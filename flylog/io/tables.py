"""Parquet tables, written atomically and streamed in row groups (bounded memory)."""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path
from types import TracebackType
from typing import Any, NamedTuple

import pyarrow as pa
import pyarrow.parquet as pq

from flylog.io.atomic import publish, temporary_beside


class Column(NamedTuple):
    """A documented column: its unit and description go into the Parquet field metadata."""

    name: str
    type: pa.DataType
    unit: str
    description: str


def schema(columns: Iterable[Column]) -> pa.Schema:
    return pa.schema(
        [
            pa.field(c.name, c.type, metadata={"description": c.description, "unit": c.unit})
            for c in columns
        ]
    )


def schema_markdown(columns: Iterable[Column]) -> str:
    """A Markdown table of the columns (for the README)."""
    lines = ["| column | type | unit | meaning |", "|---|---|---|---|"]
    lines += [f"| `{c.name}` | {c.type} | {c.unit} | {c.description} |" for c in columns]
    return "\n".join(lines)


class TableWriter:
    """``with TableWriter(path, schema) as t: t.append(row_dict)``.

    Rows are buffered and flushed every ``rows_per_group`` rows; the file appears at
    ``path`` only when the block ends without an exception (written to a temporary file
    in the same directory, then renamed).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        schema: pa.Schema,
        *,
        rows_per_group: int = 8192,
        metadata: dict[str, str] | None = None,
    ) -> None:
        self.path = Path(path)
        self.schema = schema.with_metadata(metadata) if metadata else schema
        self._rows_per_group = rows_per_group
        self._columns: dict[str, list[Any]] = {name: [] for name in schema.names}
        self._buffered = 0
        self._writer: pq.ParquetWriter | None = None
        self._tmp: Path | None = None
        self.rows = 0

    def __enter__(self) -> TableWriter:
        fd, self._tmp = temporary_beside(self.path)
        os.close(fd)
        self._writer = pq.ParquetWriter(self._tmp, self.schema, compression="zstd")
        return self

    def append(self, row: dict[str, Any]) -> None:
        for name, column in self._columns.items():
            column.append(row[name])
        self._buffered += 1
        self.rows += 1
        if self._buffered >= self._rows_per_group:
            self._flush()

    def _flush(self) -> None:
        if self._buffered == 0:
            return
        assert self._writer is not None
        self._writer.write_table(pa.table(self._columns, schema=self.schema))
        for column in self._columns.values():
            column.clear()
        self._buffered = 0

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        assert self._writer is not None and self._tmp is not None
        try:
            if exc_type is None:
                self._flush()
                self._writer.close()
                publish(self._tmp, self.path)
        finally:
            self._writer.close()
            self._tmp.unlink(missing_ok=True)
