"""The true left view the fly metrics read, rendered by the simulator on a coarser grid.

Ground truth comes from the simulator's own renderer, never from a second geometry code;
but the metrics need neither colour nor every pixel. The view is rendered with the camera's
own rig at 1/k of its width, height and focal length (k from ``MetricsConfig.truth_width``):
that rig's pixel (i, j) is the ray through the centre of the k×k pixel block (i, j) of the
full image, so the coarse view is the full view sampled at block centres, at 1/k² of the
rays. ``flylog.metrics.flies`` reads it (``views_at``, ``block=k``): a pixel sees its block's
surface, at a depth interpolated between block centres.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numba
import numpy as np

from flylog.geometry import Pose2D, StereoRig
from flylog.scene.load import Scene


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
    return dataclasses.replace(
        rig, width=rig.width // block, height=rig.height // block, focal_px=rig.focal_px / block
    )


class TrueViews:
    """Renders the true left view of a scene from true robot poses (the simulator's
    renderer; the scene is compiled once)."""

    def __init__(self, scene: Scene, rig: StereoRig, min_width: int | None = None) -> None:
        from flylog.sim.render import Renderer

        self.rig = rig
        self.block = view_block(rig, rig.width if min_width is None else min_width)
        self._renderer = Renderer(scene, block_rig(rig, self.block))

    def view(self, pose: Pose2D) -> TrueView:
        # One thread: a depth-only view is too small to share out; the parallel launch costs
        # more than it saves (~1 ms against ~12 ms a view at 160×120 on a loaded 2-core
        # machine). numba's thread count is per calling thread and is restored.
        threads = numba.get_num_threads()
        numba.set_num_threads(1)
        try:
            depth, ids = self._renderer.render_depth(pose)
        finally:
            numba.set_num_threads(threads)
        return TrueView(depth, ids, self.block)
