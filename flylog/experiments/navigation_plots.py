"""The navigation experiment's figures, and a report on one failing world per failure
mode (its map with the true trajectory, its figures and its scene file)."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from flylog.experiments import plots
from flylog.io.atomic import write_text
from flylog.scene.generate import Family


def figures(here: Path, runs: list[dict]) -> list[tuple[Path, str]]:
    families = [f.value for f in Family if any(r["family"] == f.value for r in runs)]
    out = []
    reach = [f for f in families if f != Family.DEAD_END.value]
    if reach:
        ratios = [
            [r["path_over_optimal"] for r in runs if r["family"] == f and r["goal_reached"]]
            for f in reach
        ]
        out.append(
            (
                plots.bars_figure(
                    here / "path-over-optimal.png",
                    reach,
                    ratios,
                    "path / optimal",
                    "Path length over the optimal (runs that reached the goal)",
                ),
                "True path length over the world's shortest collision-free path, one dot a run "
                "that reached the goal (box: quartiles, triangle: mean)",
            )
        )
        times = [
            [r["time_to_goal_s"] for r in runs if r["family"] == f and r["goal_reached"]]
            for f in reach
        ]
        out.append(
            (
                plots.bars_figure(
                    here / "time-to-goal.png", reach, times, "time to goal (s)", "Time to goal"
                ),
                "Time from the start to the goal, one dot a run that reached it",
            )
        )
    clearance = [[r["min_clearance_m"] for r in runs if r["family"] == f] for f in families]
    out.append(
        (
            plots.bars_figure(
                here / "clearance.png",
                families,
                clearance,
                "minimum clearance (m)",
                "Minimum clearance of each run (below 0: a collision)",
            ),
            "Smallest distance between the robot's footprint and an obstacle's over each run",
        )
    )
    dead = [r for r in runs if r["family"] == Family.DEAD_END.value]
    if dead:
        endings = sorted({r["ending"] for r in dead})
        out.append(
            (
                plots.bars_figure(
                    here / "dead-end-times.png",
                    endings,
                    [[r["end_time_s"] for r in dead if r["ending"] == e] for e in endings],
                    "time from the start (s)",
                    "dead-end: when the run ended, by its ending",
                ),
                "On the dead-end worlds, the time from the start to the run's end, by how it "
                "ended (unreachable, stuck, or the time limit: duration)",
            )
        )
    return out


def failure_reports(
    here: Path, runs: list[dict], mode_of: Callable[[dict], str | None]
) -> dict[str, tuple[list[dict], Path]]:
    """For each failure mode, its runs and the report written on the first of them
    (``failures/FAMILY-SEED.md`` beside a map of the world and the trajectory)."""
    from flylog.scene.load import load_scene

    modes: dict[str, list[dict]] = {}
    for r in runs:
        mode = mode_of(r)
        if mode is not None:
            modes.setdefault(mode, []).append(r)
    out = {}
    folder = here / "failures"
    for mode, rows in modes.items():
        first = rows[0]
        folder.mkdir(parents=True, exist_ok=True)
        name = f"{first['family']}-{first['seed']}"
        scene = load_scene(here / first["world"])
        xy = np.asarray(first["trajectory"], dtype=float).reshape(-1, 2)
        panel = plots.MapPanel(f"{name}: {mode}", paths=(plots.Path2D(xy, "true path"),))
        picture = plots.map_figure(folder / f"{name}.png", scene, [panel])
        figures = ", ".join(
            f"{k} {_fmt(first[k])}"
            for k in (
                "ending",
                "end_time_s",
                "path_length_m",
                "optimal_path_m",
                "min_clearance_m",
                "final_goal_distance_m",
                "narrowest_gap_m",
            )
        )
        touched = ", ".join(first["touched"]) or "nothing"
        text = "\n".join(
            [
                f"# {name}: {mode}",
                "",
                f"World: [{first['world']}](../{first['world']}) (regenerate it with "
                f"`flylog scene generate {first['family']} --seed {first['seed']}`).",
                "",
                f"{figures}; touched {touched}.",
                "",
                f"![{name}]({picture.name})",
                "",
                "Runs that failed this way: "
                + ", ".join(f"{r['family']} {r['seed']}" for r in rows),
                "",
            ]
        )
        report = folder / f"{name}.md"
        write_text(report, text)
        out[mode] = (rows, report)
    return out


def _fmt(value: object) -> str:
    if isinstance(value, float):
        return "nan" if not math.isfinite(value) else f"{value:.2f}"
    return str(value)
