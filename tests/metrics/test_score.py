import json
import threading

import numpy as np
import pyarrow.parquet as pq
import pytest

from flylog.errors import LogError, OutputError
from flylog.geometry import Pose2D
from flylog.io import LogWriter, contract, encode
from flylog.io.contract import CommandStatus
from flylog.metrics import tables
from flylog.metrics.config import MetricsConfig
from flylog.metrics.score import score_run
from flylog.metrics.write import write_metrics

from .helpers import surface_flies, write_run

MS = 1_000_000
TIMES = [200 * MS, 500 * MS, 800 * MS, 1100 * MS]


def test_rig_comes_from_the_metadata_not_the_scene(truth):
    assert (truth.rig.width, truth.rig.height) == (160, 120)
    assert truth.scene.spec.camera.width == 640
    assert truth.rig.focal_px == pytest.approx(truth.scene.spec.camera.focal_px / 4)


def test_flies_on_the_true_surface_score_one(sensor_log, truth, tmp_path):
    snaps = [(t, surface_flies(truth, t)) for t in TIMES]
    run = write_run(tmp_path / "run.mcap", snaps)
    result = score_run(run, sensor_log)
    s = result.summary
    assert s["snapshots"] == 4
    assert s["precision"] == 1.0
    assert s["recall"] == 1.0
    assert s["median_depth_error"] < 1e-5
    for row in result.snapshots:
        assert row["obstacle_flies"] == row["in_view"] == row["on_surface"] > 100
        # the weak half is not obstacle flies; nor are strong ones within 5 cm of the ground
        assert 0.9 * row["flies"] / 2 < row["obstacle_flies"] < row["flies"] / 2
        # the flies sit on the visible surface: the two nearest distances agree
        assert row["nearest_detected_m"] == pytest.approx(row["nearest_visible_m"], abs=1e-4)
        assert row["nearest_true_m"] <= row["nearest_visible_m"] + 1e-6
    assert s["generations"] == 120 and s["evaluations_per_s"] == pytest.approx(20000.0)
    assert s["obstacles_detected"] == s["obstacles_visible"] >= 2
    assert s["detection_latency_max_s"] == 0.0


def test_flies_off_by_twenty_percent_score_zero(sensor_log, truth, tmp_path):
    snaps = [(t, surface_flies(truth, t, scale=1.2)) for t in TIMES[:2]]
    s = score_run(write_run(tmp_path / "run.mcap", snaps), sensor_log).summary
    assert s["precision"] == 0.0 and s["recall"] == 0.0
    assert s["median_depth_error"] == pytest.approx(0.2, rel=1e-4)
    assert s["obstacles_detected"] == 0


def test_half_of_the_obstacles_covered_gives_recall_about_one_half(sensor_log, truth, tmp_path):
    t = TIMES[0]
    w = truth.rig.width
    half = surface_flies(truth, t, keep=lambda u, v, ids: u < w // 2)
    s = score_run(write_run(tmp_path / "run.mcap", [(t, half)]), sensor_log).summary
    assert s["precision"] == 1.0
    full = score_run(
        write_run(tmp_path / "full.mcap", [(t, surface_flies(truth, t))]), sensor_log
    ).snapshots[0]
    assert 0.3 < s["recall"] < 0.7
    assert s["recall"] == pytest.approx(
        result_cells(half, truth, t) / full["visible_cells"], abs=1e-12
    )


def result_cells(flies, truth, t):
    """Visible-obstacle cells holding a fly: counted here independently, from the view."""
    from .helpers import true_view

    _, ids = true_view(truth, t)
    cell = MetricsConfig().cell_px
    u, _, v, _ = truth.rig.project(flies)
    cells = {(round(b) // cell, round(a) // cell) for a, b in zip(u, v, strict=True)}
    count = 0
    for r, c in cells:
        block = ids[r * cell : (r + 1) * cell, c * cell : (c + 1) * cell]
        count += (block >= 0).sum() > 0.5 * block.size
    return count


def test_detection_latency_from_first_visible_to_first_detected(sensor_log, truth, tmp_path):
    empty = np.empty((0, 3))
    snaps = [(TIMES[0], empty), (TIMES[1], empty), (TIMES[2], surface_flies(truth, TIMES[2]))]
    result = score_run(write_run(tmp_path / "run.mcap", snaps), sensor_log)
    seen = [r for r in result.obstacles if not np.isnan(r["first_visible_s"])]
    assert seen
    t0 = truth.true.t_ns[0]
    for row in seen:
        assert row["first_visible_s"] == pytest.approx((TIMES[0] - t0) / 1e9)
        assert row["latency_s"] == pytest.approx((TIMES[2] - TIMES[0]) / 1e9)
    assert result.summary["detection_latency_mean_s"] == pytest.approx(0.6)


def test_robot_metrics_of_a_drive_through_a_box(collision_log):
    with pytest.warns(UserWarning, match="no /flies topic: only the robot is scored"):
        s = score_run(collision_log, collision_log).summary
    assert s["snapshots"] == 0  # a plain sensor log: only the robot is scored
    assert s["collisions"] == 1
    # the robot's disc (0.3) overlaps the 0.2 box fully at x = 1: clearance −0.3
    assert s["min_clearance_m"] == pytest.approx(-0.3, abs=0.02)
    assert s["goal_reached"] is True
    assert s["time_to_goal_s"] == pytest.approx(1.3, abs=0.03)
    assert s["path_length_m"] == pytest.approx(2.0, abs=0.03)
    assert s["ate_m"] == pytest.approx(0.0, abs=1e-6)  # noise-free odometry
    assert s["planner_goal_reached"] is None


def test_planner_status_and_tables_round_trip(sensor_log, truth, tmp_path):
    snaps = [(t, surface_flies(truth, t)) for t in TIMES[:2]]
    statuses = [(TIMES[0], CommandStatus.DRIVING), (TIMES[1], CommandStatus.GOAL_REACHED)]
    run = write_run(tmp_path / "run.mcap", snaps, statuses=statuses)
    result = score_run(run, sensor_log, MetricsConfig(tau=0.1))
    assert result.summary["planner_goal_reached"] is True
    out, summary, obstacles = write_metrics(result, tmp_path / "m.parquet")
    assert summary.name == "m.summary.parquet" and obstacles.name == "m.obstacles.parquet"
    snap_table = pq.read_table(out)
    assert snap_table.schema.names == [c.name for c in tables.SNAPSHOT_COLUMNS]
    assert snap_table.num_rows == 2
    field = snap_table.schema.field("nearest_true_m")
    assert field.metadata[b"unit"] == b"m"
    config = json.loads(snap_table.schema.metadata[tables.METADATA_KEY.encode()])
    assert config["tau"] == 0.1
    row = tables.read_summary(out)
    assert row["precision"] == 1.0 and row["planner_goal_reached"] is True
    assert row["time_to_goal_s"] is None  # NaN becomes null
    assert tables.read_summary(summary) == row
    assert pq.read_table(obstacles).num_rows == len(truth.scene.obstacles)


def test_snapshots_outside_the_log_are_refused(sensor_log, truth, tmp_path):
    run = write_run(tmp_path / "run.mcap", [(5_000 * MS, np.empty((0, 3)))])
    with pytest.raises(LogError, match="outside the true trajectory"):
        score_run(run, sensor_log)


def test_a_refused_truth_log_stops_the_reading_of_the_run(sensor_log, truth, tmp_path):
    """The run is read ahead in a thread from the start: an error met before its snapshots
    are scored (here in the truth log) must not leave that thread behind."""
    flies = surface_flies(truth, TIMES[0])[:50]
    run = write_run(tmp_path / "run.mcap", [(t, flies) for t in TIMES * 40])  # > read-ahead
    bare = tmp_path / "bare.mcap"
    with LogWriter(bare) as log:
        log.write(contract.TRUTH_POSE, 0, encode.pose_in_frame(Pose2D(), 0, "odom"))
    with pytest.raises(LogError, match="lacks topic") as refused:
        score_run(run, bare)
    # The traceback kept here holds score_run's frames, and so its reader: stopped anyway.
    assert refused.traceback is not None
    assert not [t for t in threading.enumerate() if t.name == "flylog-read-ahead"]


def test_a_log_without_its_scene_is_refused(tmp_path):
    path = tmp_path / "bare.mcap"
    with LogWriter(path) as log:
        for topic in (contract.TRUTH_POSE, contract.ODOM):
            log.write(topic, 0, encode.pose_in_frame(Pose2D(), 0, "odom"))
    with pytest.raises(LogError, match=r"no 'scene\.toml' attachment"):
        score_run(path, path)
    with pytest.raises(LogError, match="lacks topic"):
        score_run(path, write_run(tmp_path / "run.mcap", []))


def test_output_must_be_parquet(sensor_log, tmp_path):
    with pytest.warns(UserWarning, match="no /flies"):
        result = score_run(write_run(tmp_path / "run.mcap", []), sensor_log)
    with pytest.raises(OutputError, match=r"must end in \.parquet"):
        write_metrics(result, tmp_path / "m.csv")
