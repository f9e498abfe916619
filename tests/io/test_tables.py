import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from flylog.io.tables import TableWriter

SCHEMA = pa.schema([("t", pa.float64()), ("n", pa.int64())])


def test_rows_round_trip_across_row_groups(tmp_path):
    path = tmp_path / "steps.parquet"
    with TableWriter(path, SCHEMA, rows_per_group=3, metadata={"k": "v"}) as table:
        for i in range(7):
            table.append({"t": i * 0.5, "n": i})
    got = pq.read_table(path)
    assert got.column("n").to_pylist() == list(range(7))
    assert got.column("t").to_pylist() == [i * 0.5 for i in range(7)]
    assert pq.ParquetFile(path).metadata.num_row_groups == 3
    assert got.schema.metadata[b"k"] == b"v"


def test_failure_leaves_no_file(tmp_path):
    path = tmp_path / "steps.parquet"
    with pytest.raises(RuntimeError), TableWriter(path, SCHEMA, rows_per_group=2) as table:
        for i in range(5):
            table.append({"t": 0.0, "n": i})
        raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_columns_by_type_name_make_the_same_table_as_a_schema(tmp_path):
    from flylog.io.tables import Column, schema, schema_markdown

    named = (Column("t", "float64", "s", "time"), Column("n", "int64", "", "count"))
    typed = (Column("t", pa.float64(), "s", "time"), Column("n", pa.int64(), "", "count"))
    assert schema(named) == schema(typed)
    assert schema_markdown(named) == schema_markdown(typed)
    assert "| `t` | double | s | time |" in schema_markdown(named)
    for name, columns in (("a", named), ("b", schema(typed))):
        with TableWriter(tmp_path / f"{name}.parquet", columns, metadata={"k": "v"}) as table:
            table.append({"t": 1.5, "n": 2})
    a, b = pq.read_table(tmp_path / "a.parquet"), pq.read_table(tmp_path / "b.parquet")
    assert a.equals(b) and a.schema.equals(b.schema, check_metadata=True)
    with TableWriter(tmp_path / "empty.parquet", named):
        pass
    assert pq.read_table(tmp_path / "empty.parquet").num_rows == 0


def test_replay_s_start_imports_no_pyarrow():
    """pyarrow (~50 ms) comes with the per-step table's first row, on the planner's worker."""
    import subprocess
    import sys

    code = "import sys, flylog.cli.replay, flylog.replay.run; print('pyarrow' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
