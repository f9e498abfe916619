"""Image truth in its two kinds (/truth/disparity, /truth/depth), the same pair in two
layouts, a multiview sequence scored at its frame with truth, and logs without image truth."""

import dataclasses

import numpy as np
import pytest
from click.testing import CliRunner

from flylog.cli.main import cli
from flylog.datasets.middlebury import scene_rig
from flylog.datasets.run import import_dataset
from flylog.errors import LogError
from flylog.geometry import Pose2D
from flylog.io import contract, encode
from flylog.io.reader import open_log
from flylog.io.writer import LogWriter
from flylog.metrics.image_truth import disparity_of_depth, read_disparity_truth
from flylog.metrics.score import score_run
from flylog.replay.config import ReplayConfig
from flylog.replay.run import replay
from flylog.sources.inputs import DatasetLogWarning, log_rig
from tests.datasets.layouts import (
    plane_pair,
    write_kitti_multiview,
    write_kitti_sequence,
    write_kitti_stereo,
    write_middlebury_scene,
)
from tests.datasets.test_image_truth import RIG

CONFIG = dataclasses.replace(
    ReplayConfig(),
    engine=dataclasses.replace(ReplayConfig().engine, flies=600),
    generations_per_frame=20,
)
COLUMNS = (
    "scored_points",
    "precision",
    "recall",
    "coverage",
    "bad1",
    "bad2",
    "disparity_error_median_px",
    "median_depth_error",
)


def _scores(log, run):
    with pytest.warns(DatasetLogWarning):
        replay(log, run, CONFIG)
    return score_run(run, log).summary


def _as_depth_log(source, target):
    """``source`` (an imported one-frame log) rewritten with its truth as /truth/depth."""
    reader = open_log(source)
    rig = log_rig(reader, mounted=False)
    truth = read_disparity_truth(reader).images[0]
    depth = np.where(np.isfinite(truth), rig.depth_of_disparity(truth), np.nan)
    (pair,) = reader.stereo_pairs()
    t, left_frame = pair.stamp_ns, contract.CAMERA_FRAMES["left"]
    with LogWriter(target) as log:
        for side, topic in contract.CALIBRATION_TOPICS.items():
            log.write(topic, t, encode.camera_calibration(rig, side, t))
        for side, image in (("left", pair.left), ("right", pair.right)):
            frame = contract.CAMERA_FRAMES[side]
            log.write(contract.IMAGE_TOPICS[side], t, encode.raw_image(image, t, frame))
        log.write(contract.TRUTH_DEPTH, t, encode.disparity_image(depth, t, left_frame))
        log.add_metadata(contract.DATASET_METADATA, reader.metadata()[contract.DATASET_METADATA])
    return rig, truth


def test_depth_converts_to_the_rigs_disparity_with_doffs():
    rig = RIG
    depth = np.array([[rig.fb / (6.0 + rig.doffs), np.nan, 0.0, -1.0, np.inf]])
    got = disparity_of_depth(depth, rig)
    np.testing.assert_allclose(got[0, 0], 6.0, rtol=1e-6)
    assert np.isnan(got[0, 1:]).all()  # NaN, Z ≤ 0 and inf (as Middlebury's) are unknown


def test_the_same_truth_as_depth_or_as_disparity_gives_the_same_scores(tmp_path):
    write_middlebury_scene(tmp_path / "plane")
    (log,) = import_dataset("middlebury", tmp_path / "plane", tmp_path / "disp.mcap")
    rig, truth = _as_depth_log(log.path, tmp_path / "depth.mcap")
    back = read_disparity_truth(open_log(tmp_path / "depth.mcap"), rig).images[0]
    np.testing.assert_array_equal(np.isnan(back), np.isnan(truth))
    assert np.nanmax(np.abs(back - truth)) < 1e-5  # float32 depth and back
    by_disparity = _scores(log.path, tmp_path / "a.mcap")
    by_depth = _scores(tmp_path / "depth.mcap", tmp_path / "b.mcap")
    assert by_disparity["scored_points"] > 50
    for column in COLUMNS:
        assert by_depth[column] == pytest.approx(by_disparity[column], abs=1e-6), column


def test_the_same_pair_from_two_layouts_gives_the_same_rig_and_scores(tmp_path):
    write_middlebury_scene(tmp_path / "plane")
    left, right, disparity = plane_pair()
    write_kitti_stereo(
        tmp_path / "kitti", scene_rig(tmp_path / "plane"), [(left, right, disparity)]
    )
    (a,) = import_dataset("middlebury", tmp_path / "plane", tmp_path / "m.mcap")
    (b,) = import_dataset("kitti", tmp_path / "kitti", tmp_path / "k.mcap")
    rig_a = log_rig(open_log(a.path), mounted=False)
    rig_b = log_rig(open_log(b.path), mounted=False)
    for field in ("width", "height", "focal_px", "baseline", "cx", "cy", "doffs"):
        assert getattr(rig_b, field) == pytest.approx(getattr(rig_a, field), rel=1e-6), field
    scores_a = _scores(a.path, tmp_path / "ra.mcap")
    scores_b = _scores(b.path, tmp_path / "rb.mcap")
    assert scores_a["scored_points"] > 50
    for column in COLUMNS:
        assert scores_b[column] == pytest.approx(scores_a[column], abs=1e-6), column


def test_a_multiview_sequence_is_scored_only_while_its_frame_10_is_the_newest(tmp_path):
    # frames 09 … 11 of one textured plane; only frame 10 carries the truth
    write_middlebury_scene(tmp_path / "plane")
    rig = scene_rig(tmp_path / "plane")
    left, right, disparity = plane_pair()
    frames = [(k, left, right) for k in (9, 10, 11)]
    write_kitti_multiview(tmp_path / "kitti", rig, [frames], [disparity])
    (log,) = import_dataset("kitti", tmp_path / "kitti", tmp_path / "seq.mcap", multiview=True)
    config = dataclasses.replace(CONFIG, generations_per_frame=10, snapshot_rate=30.0)
    with pytest.warns(DatasetLogWarning):
        replay(log.path, tmp_path / "run.mcap", config)
    result = score_run(tmp_path / "run.mcap", log.path)
    stamps = [row["stamp_ns"] for row in result.snapshots]
    assert stamps and all(1_000_000_000 <= t < 1_100_000_000 for t in stamps)
    flies = open_log(tmp_path / "run.mcap").topics()[contract.FLIES].count
    assert flies > len(stamps)  # the snapshots of frames 09 and 11 are not scored
    assert result.summary["truth_images"] == 1 and result.summary["bad2"] <= 0.05


def test_metrics_on_a_log_with_true_poses_only_exit_2_saying_what_it_holds(tmp_path):
    write_middlebury_scene(tmp_path / "plane")
    rig = scene_rig(tmp_path / "plane")
    left, right, _ = plane_pair()
    frames = [(k * 100_000_000, left, right) for k in range(2)]
    write_kitti_sequence(
        tmp_path / "odo", rig, frames, [Pose2D(0.1 * k, 0.0, 0.0) for k in range(2)]
    )
    with pytest.warns(UserWarning):
        (log,) = import_dataset("kitti", tmp_path / "odo", tmp_path / "00.mcap")
    with pytest.warns(DatasetLogWarning):
        replay(
            log.path, tmp_path / "run.mcap", dataclasses.replace(CONFIG, generations_per_frame=2)
        )
    with pytest.raises(LogError, match=r"without /truth/disparity or /truth/depth; it holds"):
        score_run(tmp_path / "run.mcap", log.path)
    out = tmp_path / "m.parquet"
    result = CliRunner().invoke(
        cli, ["metrics", str(tmp_path / "run.mcap"), "--log", str(log.path), "-o", str(out)]
    )
    assert result.exit_code == 2, result.output
    said = " ".join(result.output.split())
    assert "/truth/pose (2)" in said and "ground-truth disparity or depth images only" in said
    assert not out.exists()
