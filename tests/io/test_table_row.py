"""Rows are built from their table's columns: a missing or an unknown column is an error
when the row is made or appended, not a silent null or a dropped value at writing."""

from __future__ import annotations

import pytest

from flylog.io.tables import Column, TableWriter, table_row
from flylog.metrics import tables

COLUMNS = (Column("a", "int64", "", "first"), Column("b", "float64", "m", "second"))


def test_a_row_follows_the_columns_order():
    assert list(table_row(COLUMNS, {"b": 1.5, "a": 2})) == ["a", "b"]


@pytest.mark.parametrize(
    ("values", "named"),
    [({"a": 1}, "['b']"), ({"a": 1, "b": 2.0, "c": 3}, "['c']"), ({"a": 1, "c": 3}, "['b']")],
)
def test_a_missing_or_unknown_column_is_named(values, named):
    with pytest.raises(ValueError, match="build it from the table's columns") as err:
        table_row(COLUMNS, values)
    assert named in str(err.value)


def test_the_writer_refuses_a_row_of_other_columns(tmp_path):
    with TableWriter(tmp_path / "t.parquet", COLUMNS) as table:
        table.append({"a": 1, "b": 2.0})
        with pytest.raises(ValueError, match=r"\['c'\]"):
            table.append({"a": 1, "b": 2.0, "c": 3})
        with pytest.raises(ValueError, match=r"\['b'\]"):
            table.append({"a": 1})
    assert table.rows == 1


def test_metrics_write_table_refuses_an_unknown_summary_column(tmp_path):
    row = {c.name: None for c in tables.SUMMARY_COLUMNS} | {"typo_m": 1.0}
    with pytest.raises(ValueError, match="typo_m"):
        tables.write_table(tmp_path / "s.parquet", tables.SUMMARY_COLUMNS, [row], {})
    assert not (tmp_path / "s.parquet").exists()


def test_the_shown_metrics_are_summary_columns():
    from flylog.cli import metrics

    names = {c.name for c in tables.SUMMARY_COLUMNS}
    shown = [*metrics._SHOWN, *metrics._IMAGE_SHOWN, metrics._CONFIDENCE_SHOWN]
    assert [key for key, _ in shown if key not in names] == []
