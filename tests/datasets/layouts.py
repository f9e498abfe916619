"""Small dataset folders in their published layouts, written by the tests themselves."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from flylog.datasets.images import write_png
from flylog.datasets.pfm import write_pfm

# A synthetic Middlebury scene: a textured fronto-parallel plane at DISPARITY px.
WIDTH, HEIGHT = 96, 64
FOCAL, CX, CY, DOFFS, BASELINE_MM = 120.0, 47.25, 31.5, 4.5, 160.0
DISPARITY = 8


def calib_text(f: float, cx: float, cy: float, doffs: float, baseline_mm: float,
               width: int, height: int, ndisp: int = 32) -> str:  # fmt: skip
    return (
        f"cam0=[{f} 0 {cx}; 0 {f} {cy}; 0 0 1]\n"
        f"cam1=[{f} 0 {cx + doffs}; 0 {f} {cy}; 0 0 1]\n"
        f"doffs={doffs}\nbaseline={baseline_mm}\nwidth={width}\nheight={height}\n"
        f"ndisp={ndisp}\nisint=0\nvmin=1\nvmax={ndisp - 1}\n"
    )


def plane_pair(seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(left, right, disparity): the right image is the left shifted by DISPARITY px, the
    disparity unknown (inf) in the columns the right camera does not see and in one block."""
    rng = np.random.default_rng(seed)
    wide = rng.integers(0, 256, size=(HEIGHT, WIDTH + DISPARITY, 3), dtype=np.uint8)
    left = np.ascontiguousarray(wide[:, :WIDTH])  # left pixel u sees wide[u] ...
    right = np.ascontiguousarray(wide[:, DISPARITY:])  # ... which the right sees at u − D
    disparity = np.full((HEIGHT, WIDTH), float(DISPARITY), dtype=np.float32)
    disparity[:, :DISPARITY] = np.inf
    disparity[10:20, 40:60] = np.inf
    return left, right, disparity


def write_middlebury_scene(folder: Path, seed: int = 0, *, truth: bool = True) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    left, right, disparity = plane_pair(seed)
    write_png(folder / "im0.png", left)
    write_png(folder / "im1.png", right)
    (folder / "calib.txt").write_text(calib_text(FOCAL, CX, CY, DOFFS, BASELINE_MM, WIDTH, HEIGHT))
    if truth:
        write_pfm(folder / "disp0.pfm", disparity)
