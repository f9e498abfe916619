"""KITTI layouts written from simulated frames (the corridor fixture: its true view gives the
disparity, its true trajectory the poses), imported and compared with what was written."""

import itertools
from pathlib import Path

import numpy as np
import pytest

from flylog.datasets.kitti import KittiPoseWarning
from flylog.datasets.run import import_dataset
from flylog.errors import LogError
from flylog.geometry import Pose2D, compose, relative
from flylog.io import contract
from flylog.io.reader import open_log
from flylog.metrics.image_truth import read_disparity_truth
from flylog.metrics.trajectory import PoseInterpolator
from flylog.metrics.truth import read_truth
from flylog.metrics.view import TrueViews
from flylog.replay.inputs import log_rig
from tests.datasets.layouts import write_kitti_sequence, write_kitti_stereo

CORRIDOR = Path(__file__).parents[2] / "fixtures" / "logs" / "corridor.mcap"


@pytest.fixture(scope="module")
def simulated():
    """Three stereo pairs of the corridor fixture, their times, true poses and disparities."""
    truth = read_truth(CORRIDOR)
    pairs = list(itertools.islice(open_log(CORRIDOR).stereo_pairs(), 0, 30, 10))
    poses = PoseInterpolator(truth.true)(np.array([p.stamp_ns for p in pairs]))
    views = TrueViews(truth.scene, truth.rig)
    disparities = []
    for pose in poses:
        depth = views.view(Pose2D(*pose)).depth
        d = truth.rig.disparity(depth).astype(np.float32)
        disparities.append(np.where(np.isfinite(d) & (d > 0), d, np.nan).astype(np.float32))
    return truth.rig, pairs, [Pose2D(*p) for p in poses], disparities


@pytest.mark.parametrize("calib", ["2015", "2012"])
def test_the_stereo_layout_keeps_images_calibration_and_truth(simulated, tmp_path, calib):
    rig, pairs, _, disparities = simulated
    write_kitti_stereo(
        tmp_path / "kitti", rig,
        [(p.left, p.right, d) for p, d in zip(pairs, disparities, strict=True)], calib=calib,
    )  # fmt: skip
    logs = import_dataset("kitti", tmp_path / "kitti", tmp_path / "out")
    assert [log.path.name for log in logs] == ["000000.mcap", "000001.mcap", "000002.mcap"]
    for log, pair, disparity in zip(logs, pairs, disparities, strict=True):
        reader = open_log(log.path)
        back = next(reader.stereo_pairs())
        np.testing.assert_array_equal(back.left, pair.left)
        np.testing.assert_array_equal(back.right, pair.right)
        got = log_rig(reader, mounted=False)
        # calibration files hold 7 significant digits
        for field in ("focal_px", "baseline", "cx", "cy"):
            assert getattr(got, field) == pytest.approx(getattr(rig, field), rel=1e-6), field
        assert got.doffs == pytest.approx(rig.doffs, abs=1e-4)
        truth = read_disparity_truth(reader).images[0]
        np.testing.assert_array_equal(np.isnan(truth), np.isnan(disparity))
        known = np.isfinite(disparity)
        assert known.mean() > 0.5
        # uint16 of 1/256 px: within half a step
        assert np.max(np.abs(truth[known] - disparity[known])) <= 0.5 / 256 + 1e-6
        assert reader.metadata()[contract.DATASET_METADATA]["mount"] == contract.MOUNT_NONE


def test_the_odometry_layout_keeps_timing_and_poses(simulated, tmp_path):
    rig, pairs, poses, _ = simulated
    mid = [compose(p, Pose2D(rig.mount_x, rig.mount_y, 0.0)) for p in poses]
    rel = [relative(mid[0], m) for m in mid]  # camera 0's frame at the first pair
    frames = [(p.stamp_ns, p.left, p.right) for p in pairs]
    write_kitti_sequence(tmp_path / "odometry", rig, frames, rel)
    with pytest.warns(KittiPoseWarning, match="projected on the ground plane"):
        (log,) = import_dataset("kitti", tmp_path / "odometry", tmp_path / "00.mcap")
    reader = open_log(log.path)
    assert log.frames == 3
    stamps = [m.log_time_ns for m in reader.messages([contract.LEFT_IMAGE])]
    want = [p.stamp_ns for p in pairs]
    assert np.allclose(stamps, want, rtol=1e-6, atol=1)  # times.txt: 7 significant digits
    got = [m.value.pose for m in reader.messages([contract.TRUTH_POSE])]
    for g, r in zip(got, rel, strict=True):
        assert (g.x, g.y, g.theta) == pytest.approx((r.x, r.y, r.theta), abs=2e-6)
    assert log_rig(reader, mounted=False).frame_rate == pytest.approx(1.5, rel=1e-5)
    assert contract.TRUTH_DISPARITY not in reader.topics()
    with pytest.warns(KittiPoseWarning):
        (two,) = import_dataset("kitti", tmp_path / "odometry", tmp_path / "2.mcap", limit=2)
    assert two.frames == 2 and open_log(two.path).topics()[contract.TRUTH_POSE].count == 2


def test_a_folder_off_the_kitti_layouts_names_what_is_missing(simulated, tmp_path):
    rig, pairs, _, disparities = simulated
    write_kitti_stereo(tmp_path / "k", rig, [(pairs[0].left, pairs[0].right, disparities[0])])
    (tmp_path / "k" / "training" / "image_3" / "000000_10.png").unlink()
    with pytest.raises(LogError, match=r"image_3/000000_10\.png: missing \(KITTI stereo"):
        import_dataset("kitti", tmp_path / "k", tmp_path / "x.mcap")
    with pytest.raises(LogError, match="image_2 missing: not a KITTI folder"):
        import_dataset("kitti", tmp_path, tmp_path / "x.mcap")
    assert not (tmp_path / "x.mcap").exists()
