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
