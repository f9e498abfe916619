"""The PLY writer, read back with plyfile (the run's snapshots: tests/ros2/test_run_export.py)."""

import numpy as np
import pytest
from plyfile import PlyData

from flylog.io.ply import ply_bytes, write_ply


def test_plyfile_reads_every_column_as_written(tmp_path):
    rng = np.random.default_rng(0)
    columns = [(name, rng.normal(size=7).astype(np.float32)) for name in ("x", "y", "z", "c")]
    data = PlyData.read(str(write_ply(tmp_path / "a.ply", columns, ["made by a test"])))
    vertex = data["vertex"]
    assert data.text is False and data.byte_order == "<"
    assert [p.name for p in vertex.properties] == ["x", "y", "z", "c"]
    for name, values in columns:
        np.testing.assert_array_equal(vertex[name], values)
    assert data.comments == ["made by a test"]
    empty = PlyData.read(str(write_ply(tmp_path / "b.ply", [("x", np.empty(0))])))
    assert empty["vertex"].count == 0


def test_bad_columns_are_refused():
    with pytest.raises(ValueError, match="property"):
        ply_bytes([("x", np.zeros(3)), ("y y", np.zeros(3))])
    with pytest.raises(ValueError, match="property"):
        ply_bytes([("x", np.zeros(3)), ("y", np.zeros(2))])
