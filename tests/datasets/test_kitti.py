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
from flylog.metrics.view import TrueViews
from flylog.sources import read_truth
from flylog.sources.inputs import log_rig
from tests.datasets.layouts import write_kitti_multiview, write_kitti_sequence, write_kitti_stereo

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


def _grey(image):
    return np.rint(image.mean(axis=2)).astype(np.uint8)


@pytest.mark.parametrize("calib", ["2015", "2015-calib", "2012"])
def test_the_stereo_layout_keeps_images_calibration_and_truth(simulated, tmp_path, calib):
    rig, pairs, _, disparities = simulated
    write_kitti_stereo(
        tmp_path / "kitti",
        rig,
        [(p.left, p.right, d) for p, d in zip(pairs, disparities, strict=True)],
        calib=calib,
    )
    logs = import_dataset("kitti", tmp_path / "kitti", tmp_path / "out")
    assert [log.path.name for log in logs] == ["000000.mcap", "000001.mcap", "000002.mcap"]
    for log, pair, disparity in zip(logs, pairs, disparities, strict=True):
        reader = open_log(log.path)
        back = next(reader.stereo_pairs())
        # 2012's pair with ground truth is the grey image_0/image_1
        want = (_grey(pair.left), _grey(pair.right)) if calib == "2012" else (pair.left, pair.right)
        np.testing.assert_array_equal(back.left, want[0])
        np.testing.assert_array_equal(back.right, want[1])
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


def test_the_colour_pair_of_2012_has_no_ground_truth_of_its_own(simulated, tmp_path):
    rig, pairs, _, disparities = simulated
    write_kitti_stereo(
        tmp_path / "k", rig, [(pairs[0].left, pairs[0].right, disparities[0])], calib="2012"
    )
    training = tmp_path / "k" / "training"
    for grey in ("image_0", "image_1"):
        for f in (training / grey).iterdir():
            f.unlink()
        (training / grey).rmdir()
    (log,) = import_dataset("kitti", tmp_path / "k", tmp_path / "c.mcap")
    reader = open_log(log.path)
    np.testing.assert_array_equal(next(reader.stereo_pairs()).left, pairs[0].left)
    assert contract.TRUTH_DISPARITY not in reader.topics()  # image_0's truth is not colored_0's
    assert log_rig(reader, mounted=False).focal_px == pytest.approx(rig.focal_px, rel=1e-6)


@pytest.fixture(scope="module")
def multiview(simulated, tmp_path_factory):
    """Scene 000000: frames 09, 10, 11 (three consecutive corridor pairs, the truth of the
    middle one at frame 10); scene 000001: frame 10 alone."""
    rig, _, _, _ = simulated
    truth = read_truth(CORRIDOR)
    pairs = list(itertools.islice(open_log(CORRIDOR).stereo_pairs(), 20, 23))
    pose = PoseInterpolator(truth.true)(np.array([pairs[1].stamp_ns]))[0]
    d = rig.disparity(TrueViews(truth.scene, rig).view(Pose2D(*pose)).depth)
    disparity = np.where(np.isfinite(d) & (d > 0), d, np.nan).astype(np.float32)
    scenes = [
        [(9 + k, p.left, p.right) for k, p in enumerate(pairs)],
        [(10, pairs[0].left, pairs[0].right)],
    ]
    root = tmp_path_factory.mktemp("multiview") / "kitti"
    write_kitti_multiview(root, rig, scenes, [disparity, None])
    return root, rig, pairs, disparity


def test_frames_imports_each_scene_as_a_10_hz_sequence_with_truth_at_frame_10(multiview, tmp_path):
    root, rig, pairs, disparity = multiview
    logs = import_dataset("kitti", root, tmp_path / "out", multiview=True)
    assert [(log.path.name, log.frames) for log in logs] == [("000000.mcap", 3), ("000001.mcap", 1)]
    reader = open_log(logs[0].path)
    back = list(reader.stereo_pairs())
    assert [p.stamp_ns for p in back] == [900_000_000, 1_000_000_000, 1_100_000_000]
    for got, want in zip(back, pairs, strict=True):
        np.testing.assert_array_equal(got.left, want.left)
        np.testing.assert_array_equal(got.right, want.right)
    got_rig = log_rig(reader, mounted=False)
    assert got_rig.frame_rate == pytest.approx(10.0)
    for field in ("focal_px", "baseline", "cx", "cy"):
        assert getattr(got_rig, field) == pytest.approx(getattr(rig, field), rel=1e-6), field
    truth = read_disparity_truth(reader)
    assert truth.stamps_ns.tolist() == [1_000_000_000]
    known = np.isfinite(disparity)
    np.testing.assert_array_equal(np.isfinite(truth.images[0]), known)
    assert np.max(np.abs(truth.images[0][known] - disparity[known])) <= 0.5 / 256 + 1e-6
    # the second scene's single frame, without ground truth, is a one-frame sequence at 1 s
    one = open_log(logs[1].path)
    assert [p.stamp_ns for p in one.stereo_pairs()] == [1_000_000_000]
    assert contract.TRUTH_DISPARITY not in one.topics()


def test_frames_with_limit_and_scene_and_without_frames(multiview, tmp_path):
    root, _, pairs, _ = multiview
    (two,) = import_dataset(
        "kitti", root, tmp_path / "a.mcap", scene="000000", limit=2, multiview=True
    )
    reader = open_log(two.path)
    assert [p.stamp_ns for p in reader.stereo_pairs()] == [900_000_000, 1_000_000_000]
    assert reader.topics()[contract.TRUTH_DISPARITY].count == 1
    (ten,) = import_dataset("kitti", root, tmp_path / "b.mcap", scene="000000")
    (back,) = open_log(ten.path).stereo_pairs()
    assert back.stamp_ns == 0
    np.testing.assert_array_equal(back.left, pairs[1].left)


def test_frames_refuses_a_missing_right_frame_and_other_formats_writing_nothing(
    multiview, tmp_path
):
    _, rig, pairs, disparity = multiview
    scenes = [[(9 + k, p.left, p.right) for k, p in enumerate(pairs)]]
    write_kitti_multiview(tmp_path / "k", rig, scenes, [disparity])
    (tmp_path / "k" / "training" / "image_3" / "000000_11.png").unlink()
    with pytest.raises(LogError, match=r"image_3/000000_11\.png: missing \(KITTI stereo"):
        import_dataset("kitti", tmp_path / "k", tmp_path / "x.mcap", multiview=True)
    # without --frames the scene's frame 10 is whole
    assert import_dataset("kitti", tmp_path / "k", tmp_path / "y.mcap")[0].frames == 1
    with pytest.raises(LogError, match="multiview frames are KITTI's stereo benchmarks'"):
        import_dataset("middlebury", tmp_path / "k", tmp_path / "x.mcap", multiview=True)
    assert not (tmp_path / "x.mcap").exists()


def test_a_frame_failing_while_writing_leaves_no_log_behind(multiview, tmp_path):
    _, rig, pairs, disparity = multiview
    frames = [(9 + k, p.left, p.right) for k, p in enumerate(pairs)]
    write_kitti_multiview(tmp_path / "k", rig, [frames, frames], [disparity, disparity])
    # scene 000001's frame 11 is checked to exist, and found unreadable only when written
    (tmp_path / "k" / "training" / "image_2" / "000001_11.png").write_bytes(b"not a png")
    with pytest.raises(LogError, match=r"000001_11\.png: not a readable image"):
        import_dataset("kitti", tmp_path / "k", tmp_path / "out", multiview=True)
    assert not (tmp_path / "out").exists()  # 000000.mcap, written first, is removed


def test_the_cli_imports_multiview_frames_with_frames(multiview, tmp_path):
    from click.testing import CliRunner

    from flylog.cli.main import cli

    root, *_ = multiview
    out = tmp_path / "seq.mcap"
    args = ["import", "kitti", str(root), "-o", str(out), "--frames", "--scene", "000000"]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    assert f"wrote {out} (3 stereo pairs, " in " ".join(result.output.split())
    help_text = CliRunner().invoke(cli, ["import", "--help"]).output
    assert "--frames" in help_text and "10 Hz" in help_text
