"""The true left view the fly metrics read, rendered on a coarser grid.

Ground truth comes from the simulator's own renderer, never from a second geometry code: its
depth path, which the simulator carries twice, as the compiled kernel that renders frames and
as ``flylog.sim.depth`` in numpy for batches of views (equal bit for bit, and tested so: the
metrics use the numpy one, which costs no numba start-up). The metrics need neither colour
nor every pixel. The view is rendered with the camera's
own rig at 1/k of its width, height and focal length (k from ``MetricsConfig.truth_width``):
that rig's pixel (i, j) is the ray through the centre of the k×k pixel block (i, j) of the
full image, so the coarse view is the full view sampled at block centres, at 1/k² of the
rays. ``flylog.metrics.flies`` reads it (``views_at``, ``block=k``): a pixel sees its block's
surface, at a depth interpolated between block centres.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np

from flylog.geometry import Pose2D, StereoRig
from flylog.scene.load import Scene
from flylog.sim.depth import true_depths

# Views rendered together: the working arrays of 16 views of 160x120 stay in a core's cache
# (32 take twice as long per view on the reference machine).
_RENDER_BATCH = 16


class TrueView(NamedTuple):
    """The left camera's true depth (m, inf = sky) and ids (obstacle index, -1 ground,
    -2 sky) on a grid of ``block``×``block`` pixel blocks: (height/block, width/block)."""

    depth: np.ndarray
    ids: np.ndarray
    block: int


def view_block(rig: StereoRig, min_width: int) -> int:
    """Block size of the true view: the largest k dividing the rig's width and height with
    width / k ≥ ``min_width`` (1 if there is none above 1)."""
    k = max(1, rig.width // max(1, int(min_width)))
    while rig.width % k or rig.height % k:
        k -= 1
    return k


def block_rig(rig: StereoRig, block: int) -> StereoRig:
    """The rig whose pixels are the centre rays of ``rig``'s block×block pixel blocks."""
    if rig.width % block or rig.height % block:
        msg = f"blocks of {block} px do not tile a {rig.width}x{rig.height} image"
        raise ValueError(msg)
    pp = rig.principal_point
    if pp is not None:  # block j's centre ray is pixel b·j + (b − 1)/2's
        pp = ((pp[0] - (block - 1) / 2) / block, (pp[1] - (block - 1) / 2) / block)
    return dataclasses.replace(
        rig,
        width=rig.width // block,
        height=rig.height // block,
        focal_px=rig.focal_px / block,
        principal_point=pp,
        doffs=rig.doffs / block,
    )


def nearest_visible_rotated(
    depth: np.ndarray, ids: np.ndarray, rig: StereoRig, block: int
) -> np.ndarray:
    """(S,) ground distance (m) from base_link to the nearest obstacle pixel of each stacked
    true view (S, H/block, W/block) of a rig that is not level: there a column's rows are
    not one bearing, so every pixel is back-projected."""
    centres = [np.arange(n) * block + (block - 1) / 2.0 for n in depth.shape[1:]]
    v, u = np.meshgrid(*centres, indexing="ij")
    seen = (ids >= 0) & np.isfinite(depth)
    points = rig.backproject(u, v, np.where(seen, depth, 1.0).astype(float))
    far = np.where(seen, np.hypot(points[..., 0], points[..., 1]), np.inf)
    return far.reshape(len(far), -1).min(axis=1, initial=np.inf)


class TrueViews:
    """Renders the true left view of a scene from true robot poses (the simulator's depth
    path, :func:`flylog.sim.depth.true_depths`)."""

    def __init__(self, scene: Scene, rig: StereoRig, min_width: int | None = None) -> None:
        self.rig = rig
        self.block = view_block(rig, rig.width if min_width is None else min_width)
        self._rig = block_rig(rig, self.block)
        self._footprints = scene.footprints

    def view(self, pose: Pose2D) -> TrueView:
        depth, ids = self.render(np.array([[pose.x, pose.y, pose.theta]]))
        return TrueView(depth[0], ids[0], self.block)

    def render(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(B, h, w) depths and ids (as :class:`TrueView`) from (B, 3) true poses."""
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        parts = [
            true_depths(self._footprints, self._rig, poses[i : i + _RENDER_BATCH])
            for i in range(0, len(poses), _RENDER_BATCH)
        ]
        if len(parts) == 1:
            return parts[0]
        if not parts:
            return true_depths(self._footprints, self._rig, poses)
        return np.concatenate([d for d, _ in parts]), np.concatenate([i for _, i in parts])
