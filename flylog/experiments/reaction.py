"""From an obstacle entering the cameras' view to the planner's first reaction to it.

Measured from the ground truth, outside the run: an obstacle has *entered the view* at the
first stereo frame where it covers a given share of the true left view (rendered by the
simulator's renderer from ``/truth/pose``), and the planner *reacts* at the first
``/planner/potential`` snapshot from then on where a cell on the obstacle's footprint is a
Dirichlet obstacle cell (U = 1). Used by the latency experiment and ``bench_replay``.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from flylog.geometry import StereoRig
from flylog.scene.load import Scene

# 400 pixels of a 640×480 view (paper-sized images): the same share at any resolution.
ENTERED_VIEW_SHARE = 400 / (640 * 480)


def entered_view_pixels(rig: StereoRig) -> int:
    """Pixels an obstacle must cover to have entered the view (at least one)."""
    return max(1, round(ENTERED_VIEW_SHARE * rig.width * rig.height))


def first_visible_frames(
    log: Path, scene: Scene, rig: StereoRig, min_pixels: int | None = None
) -> dict[int, int]:
    """Obstacle index → log time (ns) of the first stereo frame where it covers
    ``min_pixels`` (default :func:`entered_view_pixels`) of the true left view."""
    from flylog.geometry import Pose2D
    from flylog.io import contract
    from flylog.io.reader import open_log
    from flylog.metrics.trajectory import interpolate_poses
    from flylog.sim.render import Renderer
    from flylog.sources.trajectory import trajectory

    need = entered_view_pixels(rig) if min_pixels is None else min_pixels
    reader = open_log(log)
    poses = [(m.log_time_ns, m.value.pose) for m in reader.messages([contract.TRUTH_POSE])]
    truth = trajectory([t for t, _ in poses], [(p.x, p.y, p.theta) for _, p in poses])
    renderer = Renderer(scene, rig)
    first: dict[int, int] = {}
    for m in reader.raw_messages([contract.LEFT_IMAGE]):
        t = m.message.log_time
        pose = interpolate_poses(truth, np.array([t]))[0]
        _, ids = renderer.render_depth(Pose2D(*(float(v) for v in pose)))
        counts = np.bincount(ids[ids >= 0].ravel(), minlength=len(scene.obstacles))
        for k in np.flatnonzero(counts >= need):
            first.setdefault(int(k), t)
    return first


def footprint_cells(scene: Scene, obstacle: int, xy: np.ndarray, cell: float) -> np.ndarray:
    """(N,) bool: the cell centres ``xy`` (N, 2) within one cell of the obstacle's footprint."""
    from flylog.scene.load import distance_to_obstacles

    one = dataclasses.replace(scene, obstacles=(scene.obstacles[obstacle],))
    return distance_to_obstacles(one, xy) <= cell


def first_reactions(run: Path, scene: Scene, visible: dict[int, int]) -> dict[int, float]:
    """Obstacle index → log time (ns) of the first potential snapshot at or after the time
    it entered the view (``visible``) with a Dirichlet obstacle cell (U ≥ 1) on its
    footprint; NaN if the planner never reacted. One pass over the run."""
    from flylog.io import contract
    from flylog.io.reader import open_log

    reaction = {k: math.nan for k in visible}
    grid_key: tuple | None = None
    masks: dict[int, np.ndarray] = {}  # obstacle → its footprint cells, for the grid seen
    for m in open_log(run).messages([contract.PLANNER_POTENTIAL]):
        waiting = [k for k, t in visible.items() if math.isnan(reaction[k]) and m.log_time_ns >= t]
        if not waiting:
            if not any(math.isnan(v) for v in reaction.values()):
                break
            continue
        g = m.value
        rows, cols = g.values.shape
        key = (rows, cols, g.origin.x, g.origin.y, g.origin.theta, g.cell)
        if key != grid_key:
            j, i = np.meshgrid(np.arange(cols), np.arange(rows))
            xy = np.stack([g.origin.x + (j + 0.5) * g.cell, g.origin.y + (i + 0.5) * g.cell], -1)
            xy = xy.reshape(-1, 2)
            masks = {k: footprint_cells(scene, k, xy, g.cell) for k in visible}
            grid_key = key
        blocked = g.values.reshape(-1) >= 1.0 - 1e-6
        for k in waiting:
            if np.any(blocked[masks[k]]):
                reaction[k] = float(m.log_time_ns)
    return reaction


def reaction_delays(
    run: Path, scene: Scene, visible: dict[int, int], frame_period_ns: float
) -> dict[int, float]:
    """Obstacle index → planner reaction delay in frame periods (NaN: never reacted)."""
    reacted = first_reactions(run, scene, visible)
    return {k: (reacted[k] - visible[k]) / frame_period_ns for k in sorted(visible)}
