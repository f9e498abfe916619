"""The Middlebury 2014 / 2021 stereo layout: one scene per folder.

``im0.png`` (left), ``im1.png`` (right), ``calib.txt`` (``cam0=[f 0 cx; 0 f cy; 0 0 1]``,
``cam1=[…]``, ``doffs`` (px), ``baseline`` (mm), ``width``, ``height``, ``ndisp``, …) and
``disp0.pfm``, the left image's disparity (px, inf where unknown). The images are
rectified; cam1's cx is cam0's + doffs, so disparity = f·B/Z − doffs, the rig's convention.
The dataset gives no robot: the rig has no mount (cameras' midpoint at base_link's origin,
level).
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from functools import partial
from pathlib import Path

import numpy as np

from flylog.datasets.checks import checked_rig, checked_truth, finite
from flylog.datasets.images import read_pair
from flylog.datasets.logwrite import DatasetFrame, Source
from flylog.datasets.pfm import read_pfm
from flylog.errors import LogError
from flylog.geometry import StereoRig
from flylog.io.inputs import read_input_text

FILES = ("im0.png", "im1.png", "calib.txt")
TRUTH_FILE = "disp0.pfm"
LAYOUT = "a Middlebury 2014/2021 scene folder holds im0.png, im1.png, calib.txt and disp0.pfm"
# calib.txt's focal lengths and principal points are given to 3 decimals: cam1's cx − cam0's
# may differ from doffs by rounding.
_DOFFS_TOLERANCE_PX = 0.01

_MATRIX = re.compile(r"^\[(.*)\]$")


def is_scene(folder: Path) -> bool:
    return all((folder / name).is_file() for name in FILES)


def scenes(path: Path) -> list[Path]:
    """``path`` itself if it is a scene folder, else its sub-folders that are, by name."""
    path = Path(path)
    if not path.is_dir():
        msg = f"{path}: no such folder ({LAYOUT})"
        raise LogError(msg)
    if is_scene(path):
        return [path]
    found = sorted(p for p in path.iterdir() if p.is_dir() and is_scene(p))
    if not found:
        missing = [name for name in FILES if not (path / name).is_file()]
        msg = (
            f"{path}: not a Middlebury scene ({', '.join(missing)} missing) and no sub-folder "
            f"is one: {LAYOUT}"
        )
        raise LogError(msg)
    return found


def _matrix(text: str, path: Path, key: str) -> np.ndarray:
    found = _MATRIX.match(text.strip())
    rows = [r.split() for r in found.group(1).split(";")] if found else []
    try:
        m = np.array(rows, dtype=float)
    except ValueError:
        m = np.empty(0)
    if m.shape != (3, 3):
        msg = f"{path}: {key} is {text!r}, not a 3×3 matrix '[f 0 cx; 0 f cy; 0 0 1]'"
        raise LogError(msg)
    return m


def read_calibration(path: Path) -> dict[str, str]:
    """``key=value`` lines of calib.txt."""
    out = {}
    for line in read_input_text(path, "the calibration").splitlines():
        if "=" in line:
            key, value = line.split("=", 1)
            out[key.strip()] = value.strip()
    return out


def scene_rig(folder: Path) -> StereoRig:
    """The rectified rig calib.txt describes (no mount: the dataset gives none)."""
    path = folder / "calib.txt"
    calib = read_calibration(path)
    for key in ("cam0", "cam1", "doffs", "baseline", "width", "height"):
        if key not in calib:
            msg = (
                f"{path}: no '{key}=' line ({LAYOUT}; calib.txt gives cam0, cam1, doffs, "
                "baseline, width and height)"
            )
            raise LogError(msg)
    k0, k1 = _matrix(calib["cam0"], path, "cam0"), _matrix(calib["cam1"], path, "cam1")
    try:
        doffs, baseline_mm = float(calib["doffs"]), float(calib["baseline"])
        width, height = int(calib["width"]), int(calib["height"])
    except ValueError as exc:
        msg = f"{path}: {exc}: doffs and baseline are numbers, width and height integers"
        raise LogError(msg) from None
    for key, m in (("cam0", k0), ("cam1", k1)):
        for (i, j), name in (((0, 0), "f"), ((1, 1), "f"), ((0, 2), "cx"), ((1, 2), "cy")):
            finite(path, f"{key}'s {name}", float(m[i, j]), positive=name == "f")
    finite(path, "doffs", doffs)
    finite(path, "baseline", baseline_mm, positive=True)
    f = float(k0[0, 0])
    if not (np.isclose(k0[1, 1], f) and np.isclose(k1[0, 0], f) and np.isclose(k1[1, 1], f)):
        msg = (
            f"{path}: cam0 and cam1 must share one focal length (square pixels), got "
            f"{k0[0, 0]}, {k0[1, 1]}, {k1[0, 0]}, {k1[1, 1]}"
        )
        raise LogError(msg)
    if abs(k1[0, 2] - k0[0, 2] - doffs) > _DOFFS_TOLERANCE_PX or abs(k1[1, 2] - k0[1, 2]) > 1e-6:
        msg = (
            f"{path}: cam1's principal point ({k1[0, 2]}, {k1[1, 2]}) is not cam0's "
            f"({k0[0, 2]}, {k0[1, 2]}) shifted by doffs = {doffs} along x: not rectified"
        )
        raise LogError(msg)
    rig = StereoRig(
        width=width,
        height=height,
        focal_px=f,
        baseline=baseline_mm / 1000.0,
        mount_height=0.0,
        mount_x=0.0,
        mount_y=0.0,
        principal_point=(float(k0[0, 2]), float(k0[1, 2])),
        doffs=doffs,
    )
    return checked_rig(rig, path)


def scene_frames(folder: Path, rig: StereoRig) -> Iterator[DatasetFrame]:
    """The scene's one pair at time 0, with disp0.pfm's disparity (inf → NaN) when present."""
    left, right = read_pair(folder / "im0.png", folder / "im1.png")
    for name, image in (("im0.png", left), ("im1.png", right)):
        if image.shape[:2] != (rig.height, rig.width):
            msg = (
                f"{folder / name}: {image.shape[1]}×{image.shape[0]} px, but calib.txt says "
                f"width={rig.width}, height={rig.height}"
            )
            raise LogError(msg)
    disparity = None
    truth = folder / TRUTH_FILE
    if truth.is_file():
        disparity = read_pfm(truth)
        if disparity.ndim != 2:
            msg = f"{truth}: a colour PFM (PF); a disparity map has one channel (Pf)"
            raise LogError(msg)
        disparity = np.where(np.isfinite(disparity), disparity, np.nan).astype(np.float32)
        checked_truth(truth, disparity, (rig.width, rig.height))
    yield DatasetFrame(0, left, right, disparity)


def sources(path: Path) -> list[Source]:
    """One source per scene folder at or under ``path`` (checked before anything is read)."""
    return [Source(f.name, f, rig, partial(scene_frames, f, rig)) for f, rig in
            ((f, scene_rig(f)) for f in scenes(path))]  # fmt: skip
