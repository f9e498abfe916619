"""Impossible geometry, truth that cannot score and unreadable text in a dataset: `flylog
import` exits 2 with one line naming the file and the field, and writes nothing."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from flylog.cli.main import cli
from flylog.datasets.images import write_png
from flylog.datasets.pfm import write_pfm
from flylog.geometry import Pose2D, StereoRig
from tests.datasets.layouts import (
    BASELINE_MM,
    CX,
    CY,
    DOFFS,
    FOCAL,
    HEIGHT,
    WIDTH,
    calib_text,
    camera_in_body,
    plane_pair,
    sensor_yaml,
    write_euroc,
    write_kitti_sequence,
    write_kitti_stereo,
    write_middlebury_scene,
)

RIG = StereoRig(width=WIDTH, height=HEIGHT, focal_px=FOCAL, baseline=0.16, frame_rate=10.0)
NOT_UTF8 = b"\xff\xfe not text \x80\n"


def _calib(root: Path, **changes: object) -> None:
    values = {"f": FOCAL, "cx": CX, "cy": CY, "doffs": DOFFS, "baseline_mm": BASELINE_MM}
    values.update(changes)
    (root / "calib.txt").write_text(calib_text(**values, width=WIDTH, height=HEIGHT))  # type: ignore[arg-type]


def _line(root: Path, key: str, value: str) -> None:
    """calib.txt with the line ``key=…`` alone changed."""
    lines = (root / "calib.txt").read_text().splitlines()
    changed = [f"{key}={value}" if line.startswith(f"{key}=") else line for line in lines]
    (root / "calib.txt").write_text("\n".join(changed) + "\n")


def _pfm_scale(root: Path, scale: str) -> None:
    data = (root / "disp0.pfm").read_bytes()
    head, _, rest = data.partition(b"\n-1.0\n")
    (root / "disp0.pfm").write_bytes(head + b"\n" + scale.encode() + b"\n" + rest)


def _truth(root: Path, value: float) -> None:
    write_pfm(root / "disp0.pfm", np.full((HEIGHT, WIDTH), value, dtype=np.float32))


def _grey_left(root: Path) -> None:
    left, _, _ = plane_pair()
    write_png(root / "im0.png", np.rint(left.mean(axis=2)).astype(np.uint8))


Mutation = Callable[[Path], None]
MIDDLEBURY: list[tuple[str, Mutation, str]] = [
    ("baseline nan", lambda r: _line(r, "baseline", "nan"), "baseline is nan"),
    ("baseline inf", lambda r: _line(r, "baseline", "inf"), "baseline is inf"),
    ("baseline 0", lambda r: _line(r, "baseline", "0"), "baseline is 0"),
    ("baseline < 0", lambda r: _line(r, "baseline", "-160"), "baseline is -160"),
    ("doffs nan", lambda r: _line(r, "doffs", "nan"), "doffs is nan"),
    ("doffs inf", lambda r: _line(r, "doffs", "inf"), "doffs is inf"),
    ("focal 0", lambda r: _calib(r, f=0.0), "cam0's f is 0"),
    ("focal < 0", lambda r: _calib(r, f=-120.0), "cam0's f is -120"),
    ("pfm scale 0", lambda r: _pfm_scale(r, "0"), "PFM scale is '0'"),
    ("pfm scale nan", lambda r: _pfm_scale(r, "nan"), "PFM scale is 'nan'"),
    ("truth all unknown", lambda r: _truth(r, np.inf), "holds no known disparity"),
    ("truth all 0", lambda r: _truth(r, 0.0), "every known disparity"),
    ("grey left", _grey_left, "colour, but the left image"),
    ("calib not utf-8", lambda r: (r / "calib.txt").write_bytes(NOT_UTF8), "not UTF-8"),
]
FILES = {"grey left": "im1.png", "pfm scale 0": "disp0.pfm", "pfm scale nan": "disp0.pfm",
         "truth all unknown": "disp0.pfm", "truth all 0": "disp0.pfm"}  # fmt: skip


def _refused(args: list[str], out: Path, file: str, words: str) -> None:
    result = CliRunner().invoke(cli, ["import", *args, "-o", str(out)])
    assert result.exit_code == 2, result.output
    lines = [line for line in result.stderr.splitlines() if line.startswith("error")]
    assert len(lines) == 1, result.stderr
    assert file in lines[0] and words in lines[0], lines[0]
    assert not any(p.name.startswith(out.name) or ".part" in p.name for p in out.parent.iterdir())


@pytest.mark.parametrize(("name", "mutate", "words"), MIDDLEBURY, ids=[m[0] for m in MIDDLEBURY])
def test_middlebury(tmp_path, name, mutate, words):
    scene = tmp_path / "scene"
    write_middlebury_scene(scene)
    mutate(scene)
    _refused(["middlebury", str(scene)], tmp_path / "out.mcap", FILES.get(name, "calib.txt"), words)


@pytest.fixture
def pair():
    left, right, disparity = plane_pair()
    return left, right, np.where(np.isfinite(disparity), disparity, np.nan).astype(np.float32)


def test_kitti_truth_of_another_size(tmp_path, pair):
    left, right, _ = pair
    write_kitti_stereo(tmp_path / "k", RIG, [(left, right, np.full((48, 80), 8.0))])
    truth = "disp_occ_0/000000_10.png"
    _refused(["kitti", str(tmp_path / "k")], tmp_path / "out.mcap", truth, "80×48 values")


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("P_rect_02: " + " ".join(["0"] * 12), "left camera's focal length is 0"),
        ("P_rect_02: " + " ".join(["nan"] * 12), "not finite"),
    ],
)
def test_kitti_impossible_projection(tmp_path, pair, text, words):
    write_kitti_stereo(tmp_path / "k", RIG, [pair])
    calib = tmp_path / "k" / "training" / "calib_cam_to_cam" / "000000.txt"
    lines = [
        text if line.startswith("P_rect_02") else line for line in calib.read_text().split("\n")
    ]
    calib.write_text("\n".join(lines))
    _refused(["kitti", str(tmp_path / "k")], tmp_path / "out.mcap", "000000.txt", words)


def test_kitti_calibration_not_utf8(tmp_path, pair):
    write_kitti_stereo(tmp_path / "k", RIG, [pair])
    (tmp_path / "k" / "training" / "calib_cam_to_cam" / "000000.txt").write_bytes(NOT_UTF8)
    _refused(["kitti", str(tmp_path / "k")], tmp_path / "out.mcap", "000000.txt", "not UTF-8")


@pytest.fixture
def sequence(tmp_path, pair):
    left, right, _ = pair
    frames = [(k * 100_000_000, left, right) for k in range(3)]
    write_kitti_sequence(tmp_path / "odo", RIG, frames, [Pose2D(0.1 * k, 0, 0) for k in range(3)])
    return tmp_path / "odo" / "sequences" / "00"


@pytest.mark.parametrize(
    ("file", "text", "words"),
    [
        ("times.txt", "0.0\nabc\n0.2\n", "line 2 is 'abc'"),
        ("times.txt", "0.0\nnan\n0.2\n", "line 2 holds 'nan'"),
        ("times.txt", "0.0\n0.1\n0.1\n", "line 3 gives 0.1 s after 0.1 s"),
        ("poses", "1 0 0 0 0 1 0 0 0 0 1 0\nx\n1 0 0 0 0 1 0 0 0 0 1 0\n", "line 2 is 'x'"),
        ("poses", "1 0 0 0 0 1 0 0 0 0 1 0\n" * 2 + "1 0 0 nan 0 1 0 0 0 0 1 0\n", "line 3"),
    ],
)
def test_kitti_times_and_poses(tmp_path, sequence, file, text, words):
    path = sequence / file if file != "poses" else sequence.parents[1] / "poses" / "00.txt"
    path.write_text(text)
    _refused(["kitti", str(sequence)], tmp_path / "out.mcap", path.name, words)


@pytest.fixture
def euroc(tmp_path, pair):
    left, right, _ = pair
    frames = [(k * 100_000_000, left, right) for k in range(3)]
    truth = [(k * 100_000_000, Pose2D(0.1 * k, 0, 0)) for k in range(3)]
    write_euroc(tmp_path / "e", RIG, frames, truth)
    return tmp_path / "e" / "mav0"


def _truth_csv(text: str) -> Callable[[Path], None]:
    return lambda mav: (mav / "state_groundtruth_estimate0" / "data.csv").write_text(text)


def _same_t_bs(mav: Path) -> None:
    text = sensor_yaml(camera_in_body(RIG, "left"), RIG)
    (mav / "cam1" / "sensor.yaml").write_text(text)


def _bigger_images(mav: Path) -> None:
    for cam in ("cam0", "cam1"):
        for path in (mav / cam / "data").iterdir():
            write_png(path, np.zeros((HEIGHT + 8, WIDTH), dtype=np.uint8))


def _colour_right(mav: Path) -> None:
    path = next((mav / "cam1" / "data").iterdir())
    write_png(path, np.zeros((HEIGHT, WIDTH, 3), dtype=np.uint8))


EUROC: list[tuple[str, Mutation, str, str]] = [
    ("image size", _bigger_images, ".png", "sensor.yaml's resolution is 96×64"),
    ("colour right", _colour_right, ".png", "colour, but the left image"),
    ("same T_BS", _same_t_bs, "sensor.yaml", "T_BS put the cameras 0 m apart"),
    ("text stamp", lambda m: (m / "cam0" / "data.csv").write_text("#t,f\nabc,0.png\n"),
     "data.csv", "timestamp 'abc'"),
    ("empty truth", _truth_csv("#timestamp\n"), "data.csv", "empty"),
    ("3-column truth", _truth_csv("0,1,2\n"), "data.csv", "3 columns"),
    ("text truth stamp", _truth_csv("x,0,0,0,1,0,0,0\n"), "data.csv", "timestamp 'x'"),
    ("sensor.yaml not utf-8", lambda m: (m / "cam0" / "sensor.yaml").write_bytes(NOT_UTF8),
     "sensor.yaml", "not UTF-8"),
]  # fmt: skip


@pytest.mark.parametrize(("name", "mutate", "file", "words"), EUROC, ids=[m[0] for m in EUROC])
def test_euroc(tmp_path, euroc, name, mutate, file, words):
    mutate(euroc)
    _refused(["euroc", str(euroc.parent)], tmp_path / "out.mcap", file, words)


def test_import_limit_beyond_any_count_is_a_usage_error(tmp_path):
    write_middlebury_scene(tmp_path / "scene")
    args = ["import", "middlebury", str(tmp_path / "scene"), "-o", str(tmp_path / "o.mcap")]
    result = CliRunner().invoke(cli, [*args, "--limit", "99999999999999999999"])
    assert result.exit_code == 2 and "'--limit'" in result.stderr
    assert not (tmp_path / "o.mcap").exists()
