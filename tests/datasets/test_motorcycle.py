"""The Middlebury 2014 Motorcycle pair at quarter size, as scikit-image ships it: written in
the Middlebury layout, imported, replayed and scored against its ground truth."""

import dataclasses
import warnings

import numpy as np
import pytest
import skimage.data

from flylog.datasets.images import write_png
from flylog.datasets.pfm import write_pfm
from flylog.datasets.run import import_dataset
from flylog.io.reader import open_log
from flylog.metrics.image_truth import read_disparity_truth
from flylog.metrics.score import score_run
from flylog.replay.config import ReplayConfig, Stereo
from flylog.replay.run import replay
from flylog.sources.inputs import log_rig
from tests.datasets.layouts import calib_text, write_kitti_stereo

# Middlebury 2014 Motorcycle's calibration at the quarter size scikit-image ships (741×500).
F, CX, CY, DOFFS, BASELINE_MM = 994.978, 311.193, 254.877, 31.086, 193.001


def write_motorcycle(folder):
    """The pair in the Middlebury layout: im0.png, im1.png, calib.txt, disp0.pfm."""
    left, right, disparity = skimage.data.stereo_motorcycle()
    folder.mkdir(parents=True)
    write_png(folder / "im0.png", left)
    write_png(folder / "im1.png", right)
    write_pfm(folder / "disp0.pfm", disparity)
    (folder / "calib.txt").write_text(calib_text(F, CX, CY, DOFFS, BASELINE_MM, 741, 500, 70))
    return left, right, disparity


@pytest.fixture(scope="module")
def motorcycle(tmp_path_factory):
    root = tmp_path_factory.mktemp("middlebury")
    _, _, disparity = write_motorcycle(root / "Motorcycle")
    (log,) = import_dataset("middlebury", root, root / "motorcycle.mcap")
    return log.path, disparity


def test_the_real_pair_imports_with_its_calibration_and_unknown_pixels(motorcycle):
    log, disparity = motorcycle
    reader = open_log(log)
    rig = log_rig(reader, mounted=False)
    assert (rig.width, rig.height, rig.focal_px) == (741, 500, F)
    assert (rig.cx, rig.cy, rig.baseline) == (CX, CY, BASELINE_MM / 1000)
    assert rig.doffs == pytest.approx(DOFFS, abs=1e-9)
    truth = read_disparity_truth(reader).images[0]
    unknown = np.isinf(disparity)
    assert 0.05 < unknown.mean() < 0.1  # 7.3 % of the pixels
    np.testing.assert_array_equal(np.isnan(truth), unknown)
    np.testing.assert_array_equal(truth[~unknown], disparity[~unknown])


def test_flies_and_sgbm_on_the_real_pair_meet_their_floors(motorcycle, tmp_path):
    log, _ = motorcycle
    config = dataclasses.replace(ReplayConfig(), generations_per_frame=100)
    sgbm = dataclasses.replace(ReplayConfig(), stereo=Stereo.SGBM)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        replay(log, tmp_path / "flies.mcap", config)
        replay(log, tmp_path / "sgbm.mcap", sgbm)
    flies = score_run(tmp_path / "flies.mcap", log).summary
    dense = score_run(tmp_path / "sgbm.mcap", log).summary
    # measured (seed 0): the flies taken (1889) bad2 0.000, bad1 0.028, coverage 0.29,
    # precision 1.0, median 0.32 px; SGBM's points (1880) bad2 0.054, coverage 0.51, its
    # dense map bad2 0.061 over 86 % of the truth pixels
    assert flies["scored_points"] > 1000
    assert flies["bad2"] <= 0.02 and flies["precision"] >= 0.95
    assert flies["coverage"] >= 0.2 and flies["disparity_error_median_px"] <= 0.5
    assert dense["bad2"] <= 0.1 and dense["coverage"] >= 0.4
    assert dense["sgbm_dense_bad2"] <= 0.1 and dense["sgbm_dense_density"] >= 0.8


def test_the_pair_in_the_kitti_layout_gives_the_same_rig_and_truth(motorcycle, tmp_path):
    log, disparity = motorcycle
    rig = log_rig(open_log(log), mounted=False)
    left, right, _ = skimage.data.stereo_motorcycle()
    write_kitti_stereo(tmp_path / "kitti", rig, [(left, right, disparity)])
    (kitti,) = import_dataset("kitti", tmp_path / "kitti", tmp_path / "k.mcap")
    reader = open_log(kitti.path)
    got = log_rig(reader, mounted=False)
    for field in ("width", "height", "focal_px", "baseline", "cx", "cy", "doffs"):
        assert getattr(got, field) == pytest.approx(getattr(rig, field), rel=1e-6), field
    truth = read_disparity_truth(reader).images[0]
    known = np.isfinite(disparity)
    np.testing.assert_array_equal(np.isnan(truth), ~known)
    assert np.max(np.abs(truth[known] - disparity[known])) <= 0.5 / 256 + 1e-5
