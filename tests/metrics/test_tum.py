import math

import numpy as np
import pytest
from click.testing import CliRunner

from flylog.cli.export import export as export_command
from flylog.cli.metrics import metrics as metrics_command
from flylog.errors import LogError
from flylog.geometry import Pose2D
from flylog.metrics import tables
from flylog.metrics.tum import export_tum, tum_text
from flylog.sources.trajectory import trajectory

from .helpers import surface_flies, write_run

MS = 1_000_000


def test_tum_lines_exactly():
    traj = trajectory([1_500_000_000, 2_000_000_001], [(1.0, -2.5, 0.0), (0.25, 3.0, math.pi / 2)])
    s = math.sqrt(0.5)
    assert tum_text(traj) == (
        "1.500000000 1.000000 -2.500000 0.000000 0.000000000 0.000000000 0.000000000 1.000000000\n"
        f"2.000000001 0.250000 3.000000 0.000000 0.000000000 0.000000000 {s:.9f} {s:.9f}\n"
    )


def test_export_of_a_sensor_log_and_of_a_run(sensor_log, truth, tmp_path):
    written = export_tum(sensor_log, tmp_path / "log")
    assert set(written) == {"true", "odom"}
    lines = written["true"].read_text().splitlines()
    assert len(lines) == len(truth.true)
    fields = np.array([line.split() for line in lines], dtype=float)
    np.testing.assert_allclose(fields[:, 0], truth.true.t_ns / 1e9)
    np.testing.assert_allclose(fields[:, 1:3], truth.true.xy, atol=1e-6)
    np.testing.assert_allclose(
        2 * np.arctan2(fields[:, 6], fields[:, 7]), truth.true.xyt[:, 2], atol=1e-8
    )

    paths = [
        (t, np.array([[0.1 * k, 0.0, 0.2], [1.0, 1.0, 0.0]])) for k, t in enumerate((0, 100 * MS))
    ]
    odom = [(0, Pose2D(0, 0, 0)), (100 * MS, Pose2D(0.05, 0.01, 0.1))]
    run = write_run(tmp_path / "run.mcap", [], paths=paths, odom=odom)
    written = export_tum(run, tmp_path / "run")
    assert set(written) == {"odom", "planned"}
    planned = written["planned"].read_text().splitlines()
    assert planned[1].split()[:3] == ["0.100000000", "0.100000", "0.000000"]
    odom_lines = written["odom"].read_text().splitlines()
    assert odom_lines[1].split()[1:3] == ["0.050000", "0.010000"]
    assert float(odom_lines[1].split()[6]) == pytest.approx(math.sin(0.05))


def test_export_refuses_a_file_without_trajectories(tmp_path):
    run = write_run(tmp_path / "run.mcap", [])
    with pytest.raises(LogError, match="holds no trajectory"):
        export_tum(run, tmp_path / "out")
    result = CliRunner().invoke(export_command, [str(run), "--tum", str(tmp_path / "out")])
    assert result.exit_code == 2


def test_cli_metrics_and_export(sensor_log, truth, tmp_path):
    t = 300 * MS
    run = write_run(tmp_path / "run.mcap", [(t, surface_flies(truth, t))])
    out = tmp_path / "m.parquet"
    runner = CliRunner()
    result = runner.invoke(
        metrics_command, [str(run), "--log", str(sensor_log), "-o", str(out), "--tau", "0.02"]
    )
    assert result.exit_code == 0, result.output
    assert "precision" in result.output
    row = tables.read_summary(out)
    assert row["precision"] == 1.0 and row["snapshots"] == 1
    bad = runner.invoke(metrics_command, [str(run), "-o", str(tmp_path / "x.parquet")])
    assert bad.exit_code == 2  # the run alone has no ground truth
    exported = runner.invoke(export_command, [str(sensor_log), "--tum", str(tmp_path / "tum")])
    assert exported.exit_code == 0
    assert sorted(p.name for p in (tmp_path / "tum").iterdir()) == ["odom.tum", "true.tum"]
