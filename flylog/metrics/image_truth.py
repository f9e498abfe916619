"""Scores of points (flies, SGBM's points, SGBM's dense map) against an imported dataset's
ground-truth disparity image (``/truth/disparity``: px of the left image, NaN unknown; or
``/truth/depth``: m along the left optical axis, NaN unknown, turned into disparity
f·B/Z − doffs with the log's rig).

Definitions (``MetricsConfig`` holds τ and the cells):

- A point is *in view* if it lies in front of the left camera and its rounded left
  projection (u, v) falls inside the image. Its disparity is uL − uR (the rig's
  projection, doffs included), its depth d its distance along the left optical axis.
- The *true disparity* at (u, v): on row round(v), linear in u between the pixels ⌊u⌋ and
  ⌊u⌋ + 1 where both are known, else the value of the rounded pixel where that is known,
  else unknown. Its depth D = f·B / (disparity + doffs).
- A point is *scored* if it is in view with a known true disparity; only scored points
  count in what follows (points on unknown pixels, occluded or unmeasured, are neither
  right nor wrong).
- precision = scored points on a surface (``|d − D| ≤ τ·D``) / scored points; depth error
  ``|d − D| / D`` (median); disparity error |disparity − true| (median, px);
  bad1 / bad2 = share of the scored points off by more than 1 / 2 px.
- The left image is cut into square cells of ``cell_px`` px; a cell *has ground truth*
  when more than ``cell_obstacle_share`` of its pixels are known. recall = cells with
  ground truth holding a point on a surface / cells with ground truth; coverage = cells
  with ground truth holding a point within 2 px of the true disparity / the same cells.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from flylog.errors import LogError
from flylog.geometry import StereoRig
from flylog.io import contract
from flylog.io.decode import raw_image_fields
from flylog.io.reader import LogReader
from flylog.metrics.config import MetricsConfig

BAD1_PX = 1.0
BAD2_PX = 2.0
COVERAGE_PX = 2.0  # a cell is covered by a point within this many px of the true disparity


class ImageScore(NamedTuple):
    """Counts and errors of one set of points against one disparity image."""

    points: int  # points given
    in_view: int
    scored: int  # in view with a known true disparity
    on_surface: int
    truth_cells: int  # cells with ground truth
    covered_cells: int  # ... holding a point on a surface
    close_cells: int  # ... holding a point within COVERAGE_PX
    disparity_errors: np.ndarray  # (scored,) |disparity − true| px
    depth_errors: np.ndarray  # (scored,) |d − D| / D

    @property
    def precision(self) -> float:
        return self.on_surface / self.scored if self.scored else float("nan")

    @property
    def recall(self) -> float:
        return self.covered_cells / self.truth_cells if self.truth_cells else float("nan")

    @property
    def coverage(self) -> float:
        return self.close_cells / self.truth_cells if self.truth_cells else float("nan")


@dataclass(frozen=True)
class DisparityTruth:
    """The ground-truth disparity images of a log, in time order, each valid from its stamp
    until the next stereo frame after it (when the images change under the population)."""

    path: Path
    stamps_ns: np.ndarray  # (K,) int64
    images: list[np.ndarray]  # K × (H, W) float32
    until_ns: np.ndarray  # (K,) int64: the next left image's stamp after each (or int64 max)

    def at(self, t_ns: int) -> int | None:
        """Index of the image valid at ``t_ns``: the newest stamped at or before it, while
        no newer frame has come; None outside every image's span."""
        k = int(np.searchsorted(self.stamps_ns, t_ns, side="right")) - 1
        return k if k >= 0 and t_ns < self.until_ns[k] else None


def _float_images(reader: LogReader, topic: str) -> tuple[list[int], list[np.ndarray]]:
    stamps, images = [], []
    for raw in reader.raw_messages([topic]):
        fields = raw_image_fields(raw.message.data)
        if fields.encoding != "32FC1" or fields.step != fields.width * 4:
            msg = (
                f"{reader.path}: {topic} at {raw.message.log_time} ns is {fields.encoding} "
                f"with step {fields.step}; flylog reads 32FC1, rows packed"
            )
            raise LogError(msg)
        values = np.frombuffer(fields.data, dtype="<f4", count=fields.width * fields.height)
        images.append(values.reshape(fields.height, fields.width).astype(np.float32))
        stamps.append(raw.message.log_time)
    return stamps, images


def disparity_of_depth(depth: np.ndarray, rig: StereoRig) -> np.ndarray:
    """(H, W) float32 disparity f·B/Z − doffs of a depth image (m; NaN, inf, Z ≤ 0: unknown)."""
    z = np.asarray(depth, dtype=np.float64)
    known = np.isfinite(z) & (z > 0)
    safe = np.where(known, z, 1.0)
    return np.where(known, rig.fb / safe - rig.doffs, np.nan).astype(np.float32)


def read_disparity_truth(reader: LogReader, rig: StereoRig | None = None) -> DisparityTruth:
    """Every ``/truth/disparity`` image of the log (32FC1, little endian); without them,
    every ``/truth/depth`` image as disparity through ``rig`` (the log's)."""
    stamps, images = _float_images(reader, contract.TRUTH_DISPARITY)
    if not images and rig is not None:
        stamps, depths = _float_images(reader, contract.TRUTH_DEPTH)
        images = [disparity_of_depth(z, rig) for z in depths]
    if not images:
        msg = f"{reader.path}: no {contract.TRUTH_DISPARITY} or {contract.TRUTH_DEPTH} messages"
        raise LogError(msg)
    frames = np.array(
        [raw.message.log_time for raw in reader.raw_messages([contract.LEFT_IMAGE])],
        dtype=np.int64,
    )
    frames.sort()
    after = np.searchsorted(frames, np.array(stamps, dtype=np.int64), side="right")
    last = np.iinfo(np.int64).max
    until = np.array([frames[i] if i < len(frames) else last for i in after], dtype=np.int64)
    return DisparityTruth(reader.path, np.array(stamps, dtype=np.int64), images, until)


def truth_at(disparity: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """True disparity at sub-pixel (u, v) inside the image: on row round(v), linear in u
    where the two neighbours are known, else the rounded pixel's value (NaN: unknown)."""
    h, w = disparity.shape
    row = np.clip(np.rint(v).astype(np.int64), 0, h - 1)
    u = np.asarray(u, dtype=np.float64)
    lo = np.clip(np.floor(u).astype(np.int64), 0, w - 1)
    hi = np.minimum(lo + 1, w - 1)
    a, b = disparity[row, lo].astype(np.float64), disparity[row, hi].astype(np.float64)
    t = u - lo
    linear = a + (b - a) * t
    nearest = disparity[row, np.clip(np.rint(u).astype(np.int64), 0, w - 1)].astype(np.float64)
    return np.where(np.isfinite(a) & np.isfinite(b), linear, nearest)


def _cells(mask: np.ndarray, cell: int) -> np.ndarray:
    """(rows, cols) count of True pixels of each cell (the last ones may be partial)."""
    h, w = mask.shape
    rows, cols = -(-h // cell), -(-w // cell)
    padded = np.zeros((rows * cell, cols * cell), dtype=np.int64)
    padded[:h, :w] = mask
    return padded.reshape(rows, cell, cols, cell).sum(axis=(1, 3))


def truth_cells(disparity: np.ndarray, config: MetricsConfig) -> np.ndarray:
    """(rows, cols) bool: the cells with ground truth."""
    cell = config.cell_px
    known = _cells(np.isfinite(disparity), cell)
    h, w = disparity.shape
    ones = _cells(np.ones((h, w), dtype=bool), cell)
    return known > config.cell_obstacle_share * ones


def score_pixels(
    u: np.ndarray,
    v: np.ndarray,
    disparity: np.ndarray,
    depth: np.ndarray,
    truth: np.ndarray,
    rig: StereoRig,
    config: MetricsConfig,
) -> ImageScore:
    """Score points given by their left pixel (u, v), disparity and depth (m)."""
    u, v = np.asarray(u, dtype=np.float64), np.asarray(v, dtype=np.float64)
    h, w = truth.shape
    ru, rv = np.rint(u), np.rint(v)
    inside = (depth > 0) & (ru >= 0) & (ru <= w - 1) & (rv >= 0) & (rv <= h - 1)
    true = np.full(len(u), np.nan)
    true[inside] = truth_at(truth, u[inside], v[inside])
    scored = inside & np.isfinite(true)
    d_err = np.abs(np.asarray(disparity, dtype=np.float64)[scored] - true[scored])
    true_depth = rig.depth_of_disparity(true[scored])
    z = np.asarray(depth, dtype=np.float64)[scored]
    z_err = np.abs(z - true_depth) / true_depth
    good = z_err <= config.tau
    close = d_err <= COVERAGE_PX
    cells = truth_cells(truth, config)
    cu = ru[scored].astype(np.int64) // config.cell_px
    cv = rv[scored].astype(np.int64) // config.cell_px
    covered = np.zeros_like(cells)
    covered[cv[good], cu[good]] = True
    near = np.zeros_like(cells)
    near[cv[close], cu[close]] = True
    return ImageScore(
        points=len(u),
        in_view=int(inside.sum()),
        scored=int(scored.sum()),
        on_surface=int(good.sum()),
        truth_cells=int(cells.sum()),
        covered_cells=int((covered & cells).sum()),
        close_cells=int((near & cells).sum()),
        disparity_errors=d_err,
        depth_errors=z_err,
    )


def score_points(
    xyz: np.ndarray, truth: np.ndarray, rig: StereoRig, config: MetricsConfig
) -> ImageScore:
    """Score 3-D points in base_link (flies, SGBM's cloud) by their projections."""
    u_left, u_right, v, depth = rig.project(np.asarray(xyz, dtype=np.float64).reshape(-1, 3))
    return score_pixels(u_left, v, u_left - u_right, depth, truth, rig, config)


def score_dense(
    dense: np.ndarray, truth: np.ndarray, rig: StereoRig, config: MetricsConfig
) -> ImageScore:
    """Score a dense disparity map (px; NaN: none) at every pixel it matched."""
    v, u = np.nonzero(np.isfinite(dense))
    d = dense[v, u].astype(np.float64)
    return score_pixels(u, v, d, rig.depth_of_disparity(d), truth, rig, config)
