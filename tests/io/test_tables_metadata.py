"""Units and descriptions reach readers that keep only the Parquet file's key-value
metadata (polars, pandas and DuckDB drop Arrow's field metadata)."""

from __future__ import annotations

import json

import pyarrow.parquet as pq

from flylog.io.tables import COLUMNS_METADATA_KEY, Column, TableWriter
from flylog.metrics.tables import SUMMARY_COLUMNS, write_table

COLUMNS = (Column("t", "float64", "s", "log time"), Column("n", "int64", "", "a count"))


def test_columns_are_in_the_files_key_value_metadata(tmp_path):
    path = tmp_path / "steps.parquet"
    with TableWriter(path, COLUMNS, metadata={"k": "v"}) as table:
        table.append({"t": 0.5, "n": 1})
    kv = pq.ParquetFile(path).metadata.metadata  # the footer's key-value pairs
    assert kv[b"k"] == b"v"
    assert json.loads(kv[COLUMNS_METADATA_KEY.encode()]) == {
        "t": {"unit": "s", "description": "log time"},
        "n": {"unit": "", "description": "a count"},
    }
    assert pq.read_schema(path).field("t").metadata[b"unit"] == b"s"


def test_metrics_tables_carry_them_beside_their_own_metadata(tmp_path):
    path = tmp_path / "m.summary.parquet"
    row = {c.name: None for c in SUMMARY_COLUMNS}
    write_table(path, SUMMARY_COLUMNS, [row], {"flylog.metrics": "{}"})
    kv = pq.ParquetFile(path).metadata.metadata
    assert kv[b"flylog.metrics"] == b"{}"
    columns = json.loads(kv[COLUMNS_METADATA_KEY.encode()])
    assert list(columns) == [c.name for c in SUMMARY_COLUMNS]
    assert columns["ate_m"]["unit"] == "m"


def test_flylog_describe_shows_each_columns_unit_and_meaning(tmp_path):
    from click.testing import CliRunner

    from flylog.cli.main import cli

    path = tmp_path / "steps.parquet"
    with TableWriter(path, (Column("t_s", "float64", "s", "log time of the tick"),)) as table:
        table.append({"t_s": 0.5})
    got = CliRunner().invoke(cli, ["describe", str(path)])
    assert got.exit_code == 0, got.output
    assert "1 rows, 1 columns" in got.output
    line = next(x for x in got.output.splitlines() if "t_s" in x)
    assert "double" in line and " s " in line and "log time of the tick" in line
    (tmp_path / "not.parquet").write_text("text")
    bad = CliRunner().invoke(cli, ["describe", str(tmp_path / "not.parquet")])
    assert bad.exit_code == 2 and "not a readable Parquet file" in bad.output


# A unit's suffix in a column's name.
UNIT_SUFFIX = {
    "s": "_s",
    "m": "_m",
    "rad": "_rad",
    "deg": "_deg",
    "px": "_px",
    "ns": "_ns",
    "m/s": "_m_s",
    "rad/s": "_rad_s",
    "1/s": "_per_s",
}


def test_every_column_with_a_unit_names_it() -> None:
    """Units in every Parquet column's name (t_s, true_x_m, theta_rad, linear_m_s), so a
    reader without the metadata still knows them; columns without a unit have no suffix."""
    from flylog.metrics.tables import OBSTACLE_COLUMNS, SNAPSHOT_COLUMNS
    from flylog.replay.run import STEP_COLUMNS
    from flylog.sweep.results import HEAD_COLUMNS, TAIL_COLUMNS

    tables = (STEP_COLUMNS, SNAPSHOT_COLUMNS, SUMMARY_COLUMNS, OBSTACLE_COLUMNS)
    for column in (c for table in (*tables, HEAD_COLUMNS, TAIL_COLUMNS) for c in table):
        if column.unit:
            assert column.name.endswith(UNIT_SUFFIX[column.unit]), column
