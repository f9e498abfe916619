"""Parquet tables, written atomically and streamed in row groups (bounded memory).

Each column's unit and description are in its Arrow field metadata and, for readers that
drop field metadata (polars, pandas, DuckDB), in the file's Parquet key-value metadata too:
``flylog.columns`` holds ``{column: {"unit": …, "description": …}}`` as JSON.

pyarrow is imported when a table is first needed (a schema built, a row appended), not
with this module: replay's start (where nothing else runs) need not wait for it; its
planner worker imports it at the first row, beside the engine's work (~50 ms).
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, NamedTuple

from flylog.io.atomic import Batch, publish, temporary_beside
from flylog.io.inputs import input_path

if TYPE_CHECKING:
    import pyarrow as pa
    import pyarrow.parquet as pq


class Column(NamedTuple):
    """A documented column: its unit and description go into the Parquet field metadata.
    ``type`` is a pyarrow type or its name (``"float64"``, ``"int64"``, ``"string"``...:
    ``pyarrow.type_for_alias``)."""

    name: str
    type: Any
    unit: str
    description: str


def _arrow_type(type_: Any) -> pa.DataType:
    import pyarrow as pa

    return pa.type_for_alias(type_) if isinstance(type_, str) else type_


COLUMNS_METADATA_KEY = "flylog.columns"


def columns_metadata(columns: Iterable[Column]) -> str:
    """The ``flylog.columns`` key-value metadata of a table: each column's unit and
    description, as JSON."""
    return json.dumps({c.name: {"unit": c.unit, "description": c.description} for c in columns})


def schema(columns: Iterable[Column]) -> pa.Schema:
    """The Arrow schema of documented columns: units and descriptions in each field's
    metadata and, all together, in the schema's (the Parquet file's key-value metadata)."""
    import pyarrow as pa

    columns = tuple(columns)
    return pa.schema(
        [
            pa.field(
                c.name, _arrow_type(c.type), metadata={"description": c.description, "unit": c.unit}
            )
            for c in columns
        ],
        metadata={COLUMNS_METADATA_KEY: columns_metadata(columns)},
    )


def schema_markdown(columns: Iterable[Column]) -> str:
    """A Markdown table of the columns (for docs/metrics.md: `make docs`)."""
    lines = ["| column | type | unit | meaning |", "|---|---|---|---|"]
    lines += [
        f"| `{c.name}` | {_arrow_type(c.type)} | {c.unit} | {c.description} |" for c in columns
    ]
    return "\n".join(lines)


class TableWriter:
    """``with TableWriter(path, schema) as t: t.append(row_dict)``.

    Rows are buffered and flushed every ``rows_per_group`` rows; the file appears at
    ``path`` only when the block ends without an exception (written to a temporary file
    in the same directory, then renamed; with ``batch``, renamed with the batch's other
    outputs, :class:`flylog.io.atomic.Batch`). ``schema`` is a pyarrow schema or the
    columns to make one of (:func:`schema`), with pyarrow, when the first row comes.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        schema: pa.Schema | Sequence[Column],
        *,
        rows_per_group: int = 8192,
        metadata: dict[str, str] | None = None,
        batch: Batch | None = None,
    ) -> None:
        self.path = Path(path)
        self._batch = batch
        self._source: pa.Schema | tuple[Column, ...]
        if isinstance(schema, Sequence):  # columns (a pyarrow schema is no Sequence)
            self._source = tuple(schema)
            names = [c.name for c in self._source]
        else:
            self._source, names = schema, schema.names
        self._metadata = metadata
        self._schema: pa.Schema | None = None  # built from _source at first use
        self._rows_per_group = rows_per_group
        self._columns: dict[str, list[Any]] = {name: [] for name in names}
        self._buffered = 0
        self._writer: pq.ParquetWriter | None = None
        self._tmp: Path | None = None
        self.rows = 0

    @property
    def schema(self) -> pa.Schema:
        if self._schema is None:
            source = self._source
            out = schema(source) if isinstance(source, tuple) else source
            if self._metadata:  # added to the schema's own (flylog.columns)
                out = out.with_metadata({**(out.metadata or {}), **self._metadata})
            self._schema = out
        return self._schema

    def __enter__(self) -> TableWriter:
        fd, self._tmp = temporary_beside(self.path)
        os.close(fd)
        return self

    def _open(self) -> pq.ParquetWriter:
        if self._writer is None:
            import pyarrow.parquet as pq

            assert self._tmp is not None, "use TableWriter inside a `with` block"
            self._writer = pq.ParquetWriter(self._tmp, self.schema, compression="zstd")
        return self._writer

    def append(self, row: dict[str, Any]) -> None:
        if self._writer is None:
            self._open()
        for name, column in self._columns.items():
            column.append(row[name])
        self._buffered += 1
        self.rows += 1
        if self._buffered >= self._rows_per_group:
            self._flush()

    def _flush(self) -> None:
        if self._buffered == 0:
            return
        import pyarrow as pa

        self._open().write_table(pa.table(self._columns, schema=self.schema))
        for column in self._columns.values():
            column.clear()
        self._buffered = 0

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        assert self._tmp is not None
        try:
            if exc_type is None:
                self._flush()
                self._open().close()
                publish(self._tmp, self.path, self._batch)
                self._tmp = None  # renamed, or the batch's now
        finally:
            if self._writer is not None:
                self._writer.close()
            if self._tmp is not None:
                self._tmp.unlink(missing_ok=True)


class ColumnInfo(NamedTuple):
    """A column of a Parquet file as ``flylog describe`` shows it."""

    name: str
    type: str
    unit: str
    description: str


def describe_table(path: str | os.PathLike[str]) -> tuple[int, list[ColumnInfo]]:
    """The row count and columns of the Parquet file ``path``, each with its unit and
    description from the file's ``flylog.columns`` key-value metadata (else the field's own
    metadata; empty for a table flylog did not write). LogError if it is not Parquet."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from flylog.errors import LogError

    try:
        meta = pq.ParquetFile(input_path(path, "the table")).metadata
        arrow = pq.read_schema(input_path(path, "the table"))
    except (pa.ArrowInvalid, OSError) as exc:
        msg = f"{path}: not a readable Parquet file ({exc})"
        raise LogError(msg) from None
    kv = arrow.metadata or {}
    try:
        documented = json.loads(kv.get(COLUMNS_METADATA_KEY.encode(), b"{}"))
    except (json.JSONDecodeError, UnicodeDecodeError):
        documented = {}
    out = []
    for field in arrow:
        own = {k.decode(): v.decode() for k, v in (field.metadata or {}).items()}
        doc = documented.get(field.name, own) if isinstance(documented, dict) else own
        out.append(
            ColumnInfo(field.name, str(field.type), doc.get("unit", ""), doc.get("description", ""))
        )
    return meta.num_rows, out
