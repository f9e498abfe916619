"""The closed-loop experiment's figures: each group's trajectories on its scene's map, and
clearance and odometric drift over time."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from flylog.experiments import plots
from flylog.experiments.runs import fly_snapshots, to_world, true_poses_at

MAX_FLIES_DRAWN = 4000  # obstacle flies of seed 0 on the map, subsampled evenly


@dataclasses.dataclass(frozen=True)
class Drawn:
    """What the figures need of one run, kept after its log is deleted."""

    seed: int
    t: np.ndarray  # s
    true_xy: np.ndarray
    odom_xy: np.ndarray
    clearance_t: np.ndarray
    clearance: np.ndarray
    flies: np.ndarray | None  # world x, y of the obstacle flies (seed 0 only)


def seed0_flies(log: Path) -> np.ndarray:
    """World x, y of every obstacle fly of every snapshot (from the true pose), subsampled."""
    times, clouds = fly_snapshots(log)
    if not len(times):
        return np.empty((0, 2))
    poses = true_poses_at(log, times)
    xy = [to_world(c, p) for c, p in zip(clouds, poses, strict=True) if len(c)]
    every = np.concatenate(xy) if xy else np.empty((0, 2))
    if len(every) > MAX_FLIES_DRAWN:
        every = every[np.linspace(0, len(every) - 1, MAX_FLIES_DRAWN).astype(int)]
    return every


def figures(
    here: Path, scenes: dict, drawn: dict[str, list[Drawn]], groups: dict[str, str]
) -> list[tuple[Path, str]]:
    """A map per group (``groups``: group label → scene name) and the curves figure."""
    out = []
    for label, runs in drawn.items():
        scene = scenes[groups[label]]
        paths: list[plots.Path2D] = []
        for d in runs:
            paths.append(plots.Path2D(d.true_xy, "true", "tab:green"))
            paths.append(plots.Path2D(d.odom_xy, "odometric", "tab:orange", "--", 1.0))
        flies = next((d.flies for d in runs if d.flies is not None), None)
        file = here / f"{label.replace(' ', '-').replace('×', 'x')}.png"
        panel = plots.MapPanel(
            f"{label}: {len(runs)} seeds",
            paths=tuple(paths),
            flies=flies,
            flies_label="obstacle flies (seed 0)",
        )
        out.append(
            (
                plots.map_figure(file, scene, [panel]),
                f"`{label}`: true (green) and odometric (orange, dashed) trajectories of every "
                "seed; purple: the obstacle flies of seed 0 over the run (paper Fig. 7/8); "
                "hatched: untextured, dashed outline: sonar-absorbing",
            )
        )
    curve_panels = [
        (
            f"{label}: clearance (m)",
            [plots.Curve(label, tuple((d.clearance_t, d.clearance) for d in runs))],
        )
        for label, runs in drawn.items()
    ]
    drift = [
        plots.Curve(label, tuple((d.t, np.hypot(*(d.true_xy - d.odom_xy).T)) for d in runs))
        for label, runs in drawn.items()
    ]
    curve_panels.append(("odometric position error (m)", drift))
    out.append(
        (
            plots.curves_figure(
                here / "curves.png",
                curve_panels,
                title="Clearance to the nearest obstacle, and odometric drift (thin: seeds)",
            ),
            "Clearance (distance to the nearest obstacle minus the robot's radius; below 0: "
            "collision) and the distance between the true and odometric positions, over time",
        )
    )
    return out
