"""The rolling shutter: rows seen at their own times, its bands, the log's row period."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from flylog.geometry import Pose2D, StereoRig
from flylog.io import contract
from flylog.io.reader import open_log
from flylog.sim.camera import (
    BAND_MOTION_PX,
    arc_pose,
    band_rows,
    exposure_poses,
    frame_bands,
    shutter_bands,
)
from flylog.sim.camera_defects import CameraDefects
from flylog.sim.render import Renderer
from flylog.sources.inputs import replay_inputs
from tests.benchmarks.bench_camera_defects import without_defects
from tests.sim.cli_logs import POST, image_messages, simulate_cli

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures"
SCENES = FIXTURES / "scenes"
# fixtures/regenerate.py's command of fixtures/logs/corridor.mcap
FIXTURE_ARGS = ["--duration", "2", "--resolution", "160x120", "--seed", "0"]
SMALL = ["--duration", "0.4", "--resolution", "96x72"]
# A rig turning about its own optical centres' midpoint (mount_x 0): a turn moves the image
# by f·tan(w·t) at the centre column, whatever the depth.
RIG = StereoRig(width=320, height=240, focal_px=250.0, mount_x=0.0)


def _scene_with(tmp_path, name: str, table: str) -> Path:
    scene = tmp_path / f"{name}.toml"
    text = without_defects((SCENES / f"{name}.toml").read_text())
    scene.write_text(text + "\n[camera_defects]\n" + table)
    return scene


def _left_edge(ids: np.ndarray, obstacle: int) -> tuple[np.ndarray, np.ndarray]:
    """(rows, column of the first pixel of ``obstacle`` in each row that shows it)."""
    rows = np.nonzero((ids == obstacle).any(axis=1))[0]
    return rows, np.argmax(ids[rows] == obstacle, axis=1)


def _rolling(renderer, pose, w, period_s, rows_per_band):
    one = dataclasses.replace(CameraDefects(ideal=False), motion_samples=1)
    bands = shutter_bands(renderer.rig.height, period_s, rows_per_band)
    (frame,) = frame_bands(pose, 0.0, w, one, bands)
    return renderer.render_bands(frame)


def test_a_turn_leans_a_vertical_edge_by_f_w_p_per_row():
    # Turning left at w, row v is seen w·p·v radians later: the post's edge, near the centre
    # column, moves right by f·tan(w·p·v) ≈ f·w·p·v pixels against the frame at the stamp.
    w, period_s = 1.0, 200e-6  # a readout of 48 ms, inside the 66.7 ms frame period
    renderer = Renderer(POST, RIG)
    pose = Pose2D(0.0, 0.0, 0.0)
    still = renderer.render(pose)
    rolling = _rolling(renderer, pose, w, period_s, 1)
    rows, still_u = _left_edge(still.ids, 0)
    rows_r, rolling_u = _left_edge(rolling.ids, 0)
    assert np.array_equal(rows, rows_r) and len(rows) > 150
    shift = (rolling_u - still_u).astype(float)
    slope = np.polyfit(rows, shift, 1)[0]
    predicted = RIG.focal_px * w * period_s  # 0.05 px per row, 8 px at row 160
    # Edges are whole columns (±0.5 px a row): over ~160 rows the fitted slope is within
    # 1 / 160² px a row of the true one; tan and the edge's 0.1 rad off the centre (its
    # 1 + x² is 1.01) add 1 %: 2 % holds both.
    assert slope == pytest.approx(predicted, rel=0.02)
    # Row 0 is seen at the stamp: no shift; the last rows by f·w·p·v within a pixel.
    assert shift[0] == 0.0
    assert np.all(np.abs(shift - predicted * rows) <= 1.0)


def test_bands_of_the_chosen_height_keep_an_edge_where_exact_rows_put_it():
    w, v, period_s = math.radians(45.0), 0.5, 18.9e-6
    rows = band_rows(RIG, v, w, period_s)
    assert 1 < rows < RIG.height
    # the bound: a row at most (rows - 1) / 2 periods from its band's time moves at most
    # BAND_MOTION_PX; one more row would break it
    assert band_rows(RIG, v, w, period_s * (rows - 1) / rows) >= rows
    assert BAND_MOTION_PX == 0.1
    renderer = Renderer(POST, RIG)
    pose = Pose2D(0.0, 0.0, 0.0)
    # A row of a band is at most 0.1 px from where its own time puts it (an edge's whole
    # column flips on a few rows); at 10 times the turn rate, at most 1 px.
    for times, most_rows in ((1, 0.05), (10, 0.3)):
        exact = _rolling(renderer, pose, times * w, period_s, 1)
        banded = _rolling(renderer, pose, times * w, period_s, rows)
        _, exact_u = _left_edge(exact.ids, 0)
        _, banded_u = _left_edge(banded.ids, 0)
        assert np.abs(banded_u - exact_u).max() <= 1
        assert np.mean(banded_u != exact_u) <= most_rows
    assert band_rows(RIG, 0.0, 0.0, period_s) == RIG.height
    assert band_rows(RIG, v, w, 0.0) == RIG.height


def test_a_global_shutter_renders_the_motion_blurs_poses_whole():
    defects = CameraDefects(ideal=False)
    pose = Pose2D(1.0, 2.0, 0.3)
    bands = shutter_bands(RIG.height, 0.0, band_rows(RIG, 0.5, 0.7, 0.0))
    assert bands == [(0.0, 0, RIG.height)]
    frames = frame_bands(pose, 0.5, 0.7, defects, bands)
    assert [f[0][0] for f in frames] == exposure_poses(pose, 0.5, 0.7, defects)
    single = dataclasses.replace(defects, motion_samples=1)
    assert frame_bands(pose, 0.5, 0.7, single, bands) == [[(pose, 0, RIG.height)]]


def test_motion_blur_samples_the_exposure_around_each_bands_time():
    defects = CameraDefects(ideal=False, motion_samples=4, exposure_ms=8.0)
    pose = Pose2D(1.0, 2.0, 0.3)
    bands = shutter_bands(RIG.height, 18.9e-6, 20)
    frames = frame_bands(pose, 0.5, 0.7, defects, bands)
    assert len(frames) == 4 and all(len(f) == len(bands) for f in frames)
    for (t, first, stop), *samples in zip(bands, *frames, strict=True):
        # the poses of the motion blur centred on the band's own pose
        centre = arc_pose(pose, 0.5, 0.7, t)
        want = exposure_poses(centre, 0.5, 0.7, defects)
        for got, expected in zip(samples, want, strict=True):
            assert got[1:] == (first, stop)
            assert got[0].theta == pytest.approx(expected.theta, abs=1e-12)
            assert got[0].x == pytest.approx(expected.x, abs=1e-12)
            assert got[0].y == pytest.approx(expected.y, abs=1e-12)


def test_bands_cover_the_rows_once_each_at_its_middle_rows_time():
    bands = shutter_bands(10, 2e-5, 4)
    assert [(first, stop) for _, first, stop in bands] == [(0, 4), (4, 8), (8, 10)]
    np.testing.assert_allclose([t for t, _, _ in bands], [1.5 * 2e-5, 5.5 * 2e-5, 8.5 * 2e-5])
    assert [t for t, _, _ in shutter_bands(3, 2e-5, 1)] == [0.0, 2e-5, 4e-5]


def test_an_ideal_camera_ignores_the_row_period_bit_for_bit(tmp_path):
    scene = _scene_with(tmp_path, "corridor", "ideal = true\nrow_period_us = 200.0\n")
    out = tmp_path / "ideal.mcap"
    assert simulate_cli(scene, out, *FIXTURE_ARGS).exit_code == 0
    assert image_messages(out) == image_messages(FIXTURES / "logs" / "corridor.mcap")
    assert contract.SHUTTER_METADATA not in open_log(out).metadata()


def test_a_row_period_of_0_gives_the_realistic_cameras_images_bit_for_bit(tmp_path):
    plain = _scene_with(tmp_path, "turn", "ideal = false\n")
    zero = tmp_path / "zero.toml"
    zero.write_text(plain.read_text() + "row_period_us = 0.0\n")
    a, b = tmp_path / "a.mcap", tmp_path / "b.mcap"
    assert simulate_cli(plain, a, *SMALL).exit_code == 0
    assert simulate_cli(zero, b, *SMALL).exit_code == 0
    assert image_messages(a) == image_messages(b)
    assert contract.SHUTTER_METADATA not in open_log(b).metadata()


def test_rolling_shutter_same_seed_same_images_and_the_reader_gets_its_row_period(tmp_path):
    scene = _scene_with(tmp_path, "turn", "ideal = false\nrow_period_us = 150.0\n")
    a, b = tmp_path / "a.mcap", tmp_path / "b.mcap"
    for out in (a, b):
        result = simulate_cli(scene, out, *SMALL, "--seed", "3")
        assert result.exit_code == 0, result.output
    assert image_messages(a) == image_messages(b)
    plain = tmp_path / "plain.toml"
    plain.write_text(scene.read_text().replace("row_period_us = 150.0\n", ""))
    c = tmp_path / "c.mcap"
    assert simulate_cli(plain, c, *SMALL, "--seed", "3").exit_code == 0
    # the turn scene turns from its start: the rows after row 0 differ
    assert image_messages(a) != image_messages(c)
    reader = open_log(a)
    assert reader.metadata()[contract.SHUTTER_METADATA] == {
        "version": contract.SHUTTER_VERSION,
        "row_period_ns": "150000.0",
    }
    assert replay_inputs(reader, goal=None).row_period_ns == 150000.0
    assert replay_inputs(open_log(c), goal=None).row_period_ns == 0.0


def test_a_readout_longer_than_the_frame_period_exits_2_naming_the_field_and_fix(tmp_path):
    # 72 rows at 15 Hz: at most 925.9 us a row
    scene = _scene_with(tmp_path, "corridor", "ideal = false\nrow_period_us = 1000.0\n")
    out = tmp_path / "bad.mcap"
    result = simulate_cli(scene, out, *SMALL)
    assert result.exit_code == 2, result.output
    text = " ".join(result.output.split())
    assert "'camera_defects.row_period_us'" in text and scene.name in text
    assert "72 rows of 1000 us take 72 ms to read out" in text
    assert "lower it to at most 925.926 us" in text
    assert not out.exists()
    assert list(tmp_path.glob("*.mcap")) == []
    ok = _scene_with(tmp_path, "corridor", "ideal = false\nrow_period_us = 900.0\n")
    assert simulate_cli(ok, tmp_path / "ok.mcap", *SMALL).exit_code == 0
