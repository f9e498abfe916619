"""Cameras that are not level (tilted, rolled or panned), rendered through level ones.

The column renderer needs horizontal optical axes (an image column is then one vertical
plane). A camera turned about its optical centre sees the same rays as a level camera at
the same centre, only on another image plane: its image is the level image through the
homography K·Q·K⁻¹ (Q the rotation from the camera's optical frame to the level one),
whatever the scene's depth. Each camera of a rotated rig is therefore drawn as a level
camera at its own optical centre, with an image large enough to hold every ray of the real
one, and resampled: colours bilinearly, ids at the nearest level pixel (they stay whole
surfaces), depth in inverse depth within a surface (:func:`sample_truth`), rescaled from the
level optical axis to the camera's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flylog.errors import ConfigError
from flylog.geometry import StereoRig
from flylog.geometry.stereo import OPTICAL_TO_BASE

# Level pixels kept around the rays' hull: bilinear samples read one pixel right and below.
_MARGIN = 2
# A level image may hold at most this many times the camera's pixels (a ray near 90° from
# the level axis would need an unbounded one).
_MAX_AREA = 16


@dataclass(frozen=True)
class Warp:
    """One camera of a rotated rig as a level camera and, per pixel, where its ray lands."""

    level: StereoRig  # a single level camera (baseline 0) at this camera's optical centre
    u: np.ndarray  # (H, W) float64: level-image column of each pixel's ray
    v: np.ndarray  # (H, W) float64: level-image row
    scale: np.ndarray  # (H, W): camera depth per level depth along each ray


def _rays(rig: StereoRig, cx: float) -> np.ndarray:
    """(H, W, 3) level-frame directions (level depth per camera depth) of every pixel."""
    u, v = np.meshgrid(np.arange(rig.width, dtype=float), np.arange(rig.height, dtype=float))
    f = rig.focal_px
    cam = np.stack([(u - cx) / f, (v - rig.cy) / f, np.ones_like(u)], axis=-1)
    q = OPTICAL_TO_BASE.T @ rig.rotation()  # camera optical → level optical
    return cam @ q.T


def warps(rig: StereoRig) -> tuple[Warp, Warp]:
    """(left, right) level cameras of a rotated rig, each at its camera's optical centre."""
    rays = [_rays(rig, cx) for cx in (rig.cx, rig.cx_right)]
    if min(float(r[..., 2].min()) for r in rays) < math.cos(math.radians(80.0)):
        msg = (
            f"camera: pan {rig.pan}°, tilt {rig.tilt}° and roll {rig.roll}° turn part of the "
            f"view more than 80° from the robot's forward axis; the simulator cannot render "
            f"it: reduce them or the field of view (focal_px {rig.focal_px} px)"
        )
        raise ConfigError(msg)
    f = rig.focal_px
    out = []
    for side, cx, r in zip(("left", "right"), (rig.cx, rig.cx_right), rays, strict=True):
        a, b = f * r[..., 0] / r[..., 2], f * r[..., 1] / r[..., 2]
        # the level principal point differs from the camera's by whole pixels, so that a
        # ray the turn leaves in place lands on a level pixel centre
        lcx = cx + math.ceil(_MARGIN - float(a.min()) - cx)
        lcy = rig.cy + math.ceil(_MARGIN - float(b.min()) - rig.cy)
        width = math.ceil(lcx + float(a.max())) + _MARGIN + 1
        height = math.ceil(lcy + float(b.max())) + _MARGIN + 1
        if width * height > _MAX_AREA * rig.n_pixels:
            msg = (
                f"camera: the level image holding a {rig.width}x{rig.height} view turned by "
                f"pan {rig.pan}°, tilt {rig.tilt}°, roll {rig.roll}° would be {width}x{height} "
                f"px; reduce the angles or the field of view"
            )
            raise ConfigError(msg)
        x, y, z = rig.camera_position(side)
        level = StereoRig(
            width=width,
            height=height,
            focal_px=f,
            baseline=0.0,
            mount_height=z,
            mount_x=x,
            mount_y=y,
            principal_point=(lcx, lcy),
            frame_rate=rig.frame_rate,
        )
        out.append(Warp(level, a + lcx, b + lcy, 1.0 / r[..., 2]))
    return out[0], out[1]


def sample_colour(level_image: np.ndarray, warp: Warp) -> np.ndarray:
    """The camera's (H, W, C) uint8 image from its level camera's, bilinearly."""
    img = level_image.astype(np.float64)
    x0 = np.floor(warp.u).astype(np.intp)
    y0 = np.floor(warp.v).astype(np.intp)
    fx = (warp.u - x0)[..., None]
    fy = (warp.v - y0)[..., None]
    top = img[y0, x0] * (1.0 - fx) + img[y0, x0 + 1] * fx
    bottom = img[y0 + 1, x0] * (1.0 - fx) + img[y0 + 1, x0 + 1] * fx
    return np.floor(top * (1.0 - fy) + bottom * fy + 0.5).astype(np.uint8)


def sample_truth(
    level_depth: np.ndarray, level_ids: np.ndarray, warp: Warp
) -> tuple[np.ndarray, np.ndarray]:
    """The camera's depth (along its own optical axis) and ids from its level camera's
    (..., H', W'); leading batch axes are kept. Ids are the nearest level pixel's. Where the
    four level pixels around a ray show one surface, the depth is interpolated bilinearly in
    inverse depth (exact on a plane, where 1/depth is affine in the pixel coordinates),
    elsewhere it is the nearest pixel's."""
    x0 = np.floor(warp.u).astype(np.intp)
    y0 = np.floor(warp.v).astype(np.intp)
    fx, fy = warp.u - x0, warp.v - y0
    corners = ((y0, x0), (y0, x0 + 1), (y0 + 1, x0), (y0 + 1, x0 + 1))
    weights = ((1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy)
    ids = [level_ids[..., r, c] for r, c in corners]
    same = (ids[0] == ids[1]) & (ids[0] == ids[2]) & (ids[0] == ids[3])
    with np.errstate(divide="ignore"):
        inverse = sum(
            w / level_depth[..., r, c].astype(np.float64)
            for w, (r, c) in zip(weights, corners, strict=True)
        )
        smooth = 1.0 / inverse
    iu = np.floor(warp.u + 0.5).astype(np.intp)
    iv = np.floor(warp.v + 0.5).astype(np.intp)
    nearest = level_depth[..., iv, iu].astype(np.float64)
    depth = np.where(same, smooth, nearest) * warp.scale
    return depth.astype(level_depth.dtype), level_ids[..., iv, iu]
