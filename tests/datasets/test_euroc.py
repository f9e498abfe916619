"""The EuRoC MAV layout written from simulated frames (the corridor fixture), imported and
compared with what was written; OpenCV's rectification checked on a distorted pair."""

import itertools
from pathlib import Path

import cv2
import numpy as np
import pytest

from flylog.datasets.euroc import Camera, EurocPoseWarning, rectifier
from flylog.datasets.run import import_dataset
from flylog.errors import LogError
from flylog.geometry import Pose2D, compose
from flylog.io import contract
from flylog.io.reader import open_log
from flylog.metrics.trajectory import PoseInterpolator
from flylog.sources import read_truth
from flylog.sources.inputs import log_rig
from tests.datasets.layouts import camera_in_body, write_euroc

CORRIDOR = Path(__file__).parents[2] / "fixtures" / "logs" / "corridor.mcap"


@pytest.fixture(scope="module")
def euroc(tmp_path_factory):
    truth = read_truth(CORRIDOR)
    pairs = list(itertools.islice(open_log(CORRIDOR).stereo_pairs(), 0, 9, 4))
    frames = [(p.stamp_ns, p.left, p.right) for p in pairs]
    # the ground truth's samples around the pairs (a pair outside them has no true pose)
    t = truth.true.t_ns
    span = (t >= pairs[0].stamp_ns) & (t <= pairs[-1].stamp_ns + 20_000_000)
    samples = [
        (int(t), Pose2D(*p))
        for t, p in zip(truth.true.t_ns[span], truth.true.xyt[span], strict=True)
    ]
    root = tmp_path_factory.mktemp("euroc") / "MH_01"
    write_euroc(root, truth.rig, frames, samples)
    with pytest.warns(EurocPoseWarning, match="projected on the ground plane"):
        (log,) = import_dataset("euroc", root, root.parent / "MH_01.mcap")
    return truth, pairs, log


def test_the_euroc_layout_keeps_images_calibration_timing_and_poses(euroc):
    truth, pairs, log = euroc
    rig = truth.rig
    reader = open_log(log.path)
    assert log.frames == 3 and log.path.name == "MH_01.mcap"
    back = list(reader.stereo_pairs())
    assert [b.stamp_ns for b in back] == [p.stamp_ns for p in pairs]  # ns stamps exact
    for b, p in zip(back, pairs, strict=True):
        for got, raw in ((b.left, p.left), (b.right, p.right)):
            grey = np.rint(raw.mean(axis=2)).astype(np.uint8)
            assert got.ndim == 2  # EuRoC's cameras are grey
            # rectifying an undistorted, parallel pair is the identity, to OpenCV's maps
            assert np.abs(got.astype(int) - grey).max() <= 1
    got = log_rig(reader, mounted=False)
    for field in ("focal_px", "baseline", "cx", "cy"):
        assert getattr(got, field) == pytest.approx(getattr(rig, field), rel=1e-6), field
    assert got.doffs == pytest.approx(0.0, abs=1e-9)
    assert got.frame_rate == pytest.approx(15.0 / 4, rel=1e-6)
    poses = PoseInterpolator(truth.true)(np.array([p.stamp_ns for p in pairs]))
    for m, pose in zip(reader.messages([contract.TRUTH_POSE]), poses, strict=True):
        mid = compose(Pose2D(*pose), Pose2D(rig.mount_x, rig.mount_y, 0.0))
        g = m.value.pose
        assert (g.x, g.y, g.theta) == pytest.approx((mid.x, mid.y, mid.theta), abs=1e-6)
    assert reader.metadata()[contract.DATASET_METADATA]["mount"] == contract.MOUNT_NONE


def test_opencv_rectification_maps_each_rectified_pixel_to_its_raw_distorted_pixel(euroc):
    rig = euroc[0].rig
    k = np.array([[130.0, 0.0, 82.0], [0.0, 128.0, 57.0], [0.0, 0.0, 1.0]])
    d0, d1 = np.array([-0.28, 0.07, 2e-4, 2e-5]), np.array([-0.27, 0.068, -1e-4, 3e-5])
    turn = cv2.Rodrigues(np.array([0.01, -0.02, 0.005]))[0]
    t0, t1 = camera_in_body(rig, "left"), camera_in_body(rig, "right")
    t1[:3, :3] = t1[:3, :3] @ turn  # the right camera slightly turned: rectification undoes it
    cam0, cam1 = Camera(t0, k, d0, (160, 120)), Camera(t1, k, d1, (160, 120))
    rect = rectifier(cam0, cam1)
    r = rect.rig
    r1t = np.linalg.inv(cam0.t_bs) @ rect.left_in_body  # rectified left → raw cam0
    t_10 = np.linalg.inv(cam1.t_bs) @ cam0.t_bs
    for u, v, depth in ((80, 60, 2.0), (20, 30, 3.5), (140, 100, 1.2)):
        ray = np.array([(u - r.cx) / r.focal_px, (v - r.cy) / r.focal_px, 1.0]) * depth
        x0 = r1t[:3, :3] @ ray
        raw, _ = cv2.projectPoints(x0[None], np.zeros(3), np.zeros(3), k, d0)
        mx, my = rect.maps[0]
        assert (mx[v, u], my[v, u]) == pytest.approx(tuple(raw.ravel()), abs=0.02)
        # the right camera's pixel of the same row, at the point's disparity
        left_x = ray + np.array([r.baseline, 0.0, 0.0])  # the point the right pixel (u, v) sees
        x1 = t_10[:3, :3] @ (r1t[:3, :3] @ left_x) + t_10[:3, 3]
        raw1, _ = cv2.projectPoints(x1[None], np.zeros(3), np.zeros(3), k, d1)
        mx1, my1 = rect.maps[1]
        assert (mx1[v, u], my1[v, u]) == pytest.approx(tuple(raw1.ravel()), abs=0.02)


def test_a_folder_off_the_euroc_layout_names_what_is_missing(tmp_path):
    (tmp_path / "mav0" / "cam0" / "data").mkdir(parents=True)
    with pytest.raises(LogError, match=r"mav0/cam0/data\.csv: missing \(EuRoC MAV"):
        import_dataset("euroc", tmp_path, tmp_path / "x.mcap")
    assert not (tmp_path / "x.mcap").exists()
