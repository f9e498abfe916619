"""Asynchronous flies versus the conventional synchronous pipeline (paper §2.4, Table 1).

*async*: the engine runs generation after generation on the newest images and publishes
after each; *sync*: a frame is usable only once its capture cycle has ended and results are
published when its processing has ended, with the generations the same compute budget
affords in one frame period; *SGBM*: OpenCV StereoSGBM on complete frames in the same
synchronous pipeline (the conventional method), when replay offers it (``stereo = sgbm``).

Two measures on ``turn`` (the robot turns on the spot, so obstacles keep entering the view):
the *detection latency* of each obstacle (``flylog metrics``: from the first snapshot where
it is visible to the first where 5 obstacle flies lie on it) and the *planner reaction*
(from the first frame where it covers 400/(640·480) of the true view to the first
potential snapshot with an obstacle cell on its footprint); and the fly precision and
recall of a replay of ``corridor``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flylog.config import replace_dotted
from flylog.experiments import plots
from flylog.experiments.cells import ExperimentCell, ExperimentPlan, log_seconds_work
from flylog.experiments.common import (
    Column,
    Count,
    ExperimentOptions,
    ExperimentResult,
    Table,
    experiment_dir,
    spread,
)
from flylog.experiments.markdown import finish_experiment
from flylog.experiments.reaction import first_visible_frames, reaction_delays
from flylog.experiments.runs import replay_and_score, simulate_scene
from flylog.replay.config import ReplayConfig

NAME = "latency"
TURN, CORRIDOR = "turn", "corridor"
SNAPSHOTS_PER_FRAME = 2  # snapshot clock of the turn runs: half a frame period resolution
PAPER_PIXELS = 640 * 480
# The scripted corridor drive reaches its goal in about 25 s; the scene's own duration may
# be longer (it is sized for the closed loop), which would only add standing still.
CORRIDOR_DURATION = 30.0  # s
TURN_DURATION = 8.0  # s: the turn scene's 120° sweep


def sgbm_available() -> bool:
    """Whether replay offers the SGBM baseline (``ReplayConfig.stereo``)."""
    return "stereo" in {f.name for f in dataclasses.fields(ReplayConfig)}


def mode_configs(
    options: ExperimentOptions, frame_rate: float, snapshot_rate: float
) -> dict[str, ReplayConfig]:
    """The compared pipelines, each with the same compute budget per frame."""
    base = replace_dotted(
        ReplayConfig(), {"snapshot_rate": snapshot_rate, "engine.flies": options.flies}
    )
    flies = base.engine.flies
    # sync processes each complete frame with the generations the budget affords in one
    # frame period (paper Table 1: processing takes one cycle); a generation evaluates the
    # offspring, about half the population.
    per_frame = max(1, round(base.evals_per_second / frame_rate / (flies / 2)))
    modes = {
        "async flies": base,
        f"sync flies ({per_frame} gen/frame)": replace_dotted(
            base, {"sync": True, "generations_per_frame": per_frame}
        ),
    }
    if sgbm_available():
        from flylog.replay.config import Stereo

        w, h = options.resolution
        # the baseline's cost is measured at 640×480; it scales with the pixel count
        cost = base.sgbm.seconds_per_frame * w * h / PAPER_PIXELS
        modes["sync SGBM"] = replace_dotted(
            base, {"stereo": Stereo.SGBM, "sgbm.seconds_per_frame": cost}
        )
    return modes


@dataclass(frozen=True)
class _Cell:
    """One seed's log of one scene, replayed in every pipeline of ``modes``."""

    here: Path
    options: ExperimentOptions
    scene: str
    seed: int
    duration: float
    modes: dict[str, ReplayConfig]


def plan_latency(out_dir: Path, options: ExperimentOptions) -> ExperimentPlan:
    """One cell per scene and seed; the experiment writes ``out_dir/latency/``."""
    from flylog.scene.load import load_scene

    here = experiment_dir(out_dir, NAME)
    turn = load_scene(options.scene_path(TURN))
    options.scene_path(CORRIDOR)  # a missing scene file fails before any cell runs
    frame_rate = turn.spec.camera.frame_rate
    period_s = 1.0 / frame_rate
    modes = mode_configs(options, frame_rate, SNAPSHOTS_PER_FRAME * frame_rate)
    replay_modes = mode_configs(options, frame_rate, ReplayConfig().snapshot_rate)
    cells = []
    for seed in range(options.seeds):
        for scene, duration, configs in (
            (TURN, options.duration_or(TURN_DURATION), modes),
            (CORRIDOR, options.duration_or(CORRIDOR_DURATION), replay_modes),
        ):
            task = _Cell(here, options, scene, seed, duration, configs)
            work = log_seconds_work(duration, len(configs))
            cells.append(ExperimentCell(NAME, f"{scene}, seed {seed}", work, _run_cell, task))

    def assemble(results: list[list[dict]]) -> ExperimentResult:
        runs = [run for rows in results for run in rows]
        return _finish(here, options, runs, list(modes), frame_rate, period_s)

    return ExperimentPlan(NAME, tuple(cells), assemble)


def _run_cell(task: _Cell) -> list[dict]:
    """The cell's rows, one per pipeline (its logs are deleted unless kept)."""
    here, seed = task.here, task.seed
    log = here / "runs" / f"{task.scene}_s{seed}.mcap"
    simulate_scene(task.options, task.scene, seed, log, task.duration)
    made = [log]
    rows = []
    measure = _turn_rows if task.scene == TURN else _corridor_rows
    for mode, row, run in measure(task, log):
        made.append(run)
        rows.append({"scene": task.scene, "mode": mode, "seed": seed, **row})
    if not task.options.keep_logs:  # the logs are large: free the disk cell by cell
        for path in made:
            path.unlink()
    return rows


def _turn_rows(task: _Cell, log: Path) -> Iterator[tuple[str, dict, Path]]:
    from flylog.scene.load import load_scene
    from flylog.sources import read_truth

    turn = load_scene(task.options.scene_path(TURN))
    period_s = 1.0 / turn.spec.camera.frame_rate
    visible = first_visible_frames(log, turn, read_truth(log).rig)
    for mode, config in task.modes.items():
        config = dataclasses.replace(config, seed=task.seed)
        run = task.here / "runs" / f"turn_s{task.seed}_{_slug(mode)}.mcap"
        scored = replay_and_score(log, run, config)
        delays = reaction_delays(run, turn, visible, 1e9 * period_s)
        detection = [o["latency_s"] / period_s for o in scored.obstacles]
        seen = [o for o in scored.obstacles if math.isfinite(o["first_visible_s"])]
        row = {
            "obstacles_visible": len(seen),
            "detection_frames": [d for d in detection if math.isfinite(d)],
            "entered_view": len(visible),
            "reaction_frames": [d for d in delays.values() if math.isfinite(d)],
        }
        yield mode, row, run


def _corridor_rows(task: _Cell, log: Path) -> Iterator[tuple[str, dict, Path]]:
    for mode, config in task.modes.items():
        config = dataclasses.replace(config, seed=task.seed)
        run = task.here / "runs" / f"corridor_s{task.seed}_{_slug(mode)}.mcap"
        s = replay_and_score(log, run, config).summary
        yield mode, {k: s[k] for k in ("precision", "recall", "f_score", "median_depth_error")}, run


def _finish(
    here: Path,
    options: ExperimentOptions,
    runs: list[dict],
    modes: list[str],
    frame_rate: float,
    period_s: float,
) -> ExperimentResult:
    table = _table(runs, modes, options.seeds, period_s)
    figures = _figures(here, table, runs, modes)
    findings = _findings(table)
    setup = [
        f"`{TURN}` ({options.duration_or(TURN_DURATION):g} s) and `{CORRIDOR}` "
        f"({options.duration_or(CORRIDOR_DURATION):g} s, the scene's waypoints), "
        f"{options.resolution[0]}×{options.resolution[1]} pixels, {frame_rate:g} Hz "
        f"(one frame period = {1000 * period_s:.1f} ms)",
        f"compute budget {ReplayConfig().evals_per_second:g} fitness evaluations/s for the "
        f"flies (virtual clock); snapshots {SNAPSHOTS_PER_FRAME}× per frame on `{TURN}`, "
        f"{ReplayConfig().snapshot_rate:g} Hz on `{CORRIDOR}`",
        "SGBM: `stereo = sgbm` (frame-synchronous, "
        "seconds_per_frame scaled from 640×480 by the pixel count)"
        if sgbm_available()
        else "SGBM: not available in this replay (no `ReplayConfig.stereo`): rows left out",
        f"{options.seeds} seeds (0…{options.seeds - 1}); latencies are pooled over every "
        "obstacle of every seed (median, mean); precision and recall mean ± std over seeds",
    ]
    return finish_experiment(
        NAME,
        here,
        options,
        title="Asynchronous versus synchronous detection (paper Table 1)",
        intro=__doc__ or "",
        table=table,
        findings=findings,
        figures=figures,
        setup=setup,
        runs=runs,
    )


def _slug(mode: str) -> str:
    return mode.split(" (")[0].replace(" ", "_")


def _median(values: list[float]) -> float:
    return float(np.median(values)) if values else math.nan


def _mean(values: list[float]) -> float:
    return float(np.mean(values)) if values else math.nan


def _pooled(runs: list[dict], mode: str, key: str) -> list[float]:
    return [d for r in runs if r["scene"] == TURN and r["mode"] == mode for d in r[key]]


def _table(runs: list[dict], modes: list[str], seeds: int, period_s: float) -> Table:
    """A row per pipeline: latencies pooled over every obstacle of every seed, in frame
    periods and in milliseconds (``period_s`` the frame period), and the corridor's scores."""
    ms = 1000.0 * period_s
    rows = []
    for mode in modes:
        turn = [r for r in runs if r["scene"] == TURN and r["mode"] == mode]
        corridor = [r for r in runs if r["scene"] == CORRIDOR and r["mode"] == mode]
        detection = _pooled(runs, mode, "detection_frames")
        reaction = _pooled(runs, mode, "reaction_frames")
        rows.append(
            {
                "mode": mode,
                "detection_median": _median(detection),
                "detection_mean": _mean(detection),
                "detection_median_ms": ms * _median(detection),
                "detected": Count(len(detection), sum(r["obstacles_visible"] for r in turn)),
                "reaction_median": _median(reaction),
                "reaction_mean": _mean(reaction),
                "reaction_median_ms": ms * _median(reaction),
                "reacted": Count(len(reaction), sum(r["entered_view"] for r in turn)),
                "precision": spread([r["precision"] for r in corridor]),
                "recall": spread([r["recall"] for r in corridor]),
                "f_score": spread([r["f_score"] for r in corridor]),
            }
        )
    columns = (
        Column("mode", "pipeline"),
        Column("detection_median", "detection latency, median (frames)", ".2f"),
        Column("detection_mean", "detection latency, mean (frames)", ".2f"),
        Column("detection_median_ms", "detection latency, median (ms)", ".0f"),
        Column("detected", "obstacles detected"),
        Column("reaction_median", "planner reaction, median (frames)", ".2f"),
        Column("reaction_mean", "planner reaction, mean (frames)", ".2f"),
        Column("reaction_median_ms", "planner reaction, median (ms)", ".0f"),
        Column("reacted", "planner reacted"),
        Column("precision", f"precision ({CORRIDOR})"),
        Column("recall", f"recall ({CORRIDOR})"),
        Column("f_score", f"F ({CORRIDOR})"),
    )
    return Table(f"Latency on `{TURN}`, flies on `{CORRIDOR}`, {seeds} seeds", columns, tuple(rows))


def _findings(table: Table) -> list[str]:
    out = []
    for row in table.rows:
        out.append(
            f"{row['mode']}: median detection latency {row['detection_median']:.2f} frame "
            f"periods ({row['detection_median_ms']:.0f} ms), planner reaction "
            f"{row['reaction_median']:.2f} frame periods ({row['reaction_median_ms']:.0f} ms); "
            f"corridor precision {row['precision'].mean:.3f}, recall {row['recall'].mean:.3f}"
        )
    first = table.rows[0]
    if math.isfinite(first["detection_median"]):
        verdict = "at most" if first["detection_median"] <= 1.0 else "MORE than"
        out.append(f"asynchronous flies: median detection latency {verdict} one frame period")
    return out


def _figures(
    here: Path, table: Table, runs: list[dict], modes: list[str]
) -> list[tuple[Path, str]]:
    labels = [m.split(" (")[0] for m in modes]
    return [
        (
            plots.bars_figure(
                here / "detection.png",
                labels,
                [_pooled(runs, m, "detection_frames") for m in modes],
                "frame periods",
                f"Obstacle detection latency on {TURN} (every obstacle, every seed)",
            ),
            "Detection latency per obstacle (visible → 5 obstacle flies on it), in frame periods",
        ),
        (
            plots.bars_figure(
                here / "reaction.png",
                labels,
                [_pooled(runs, m, "reaction_frames") for m in modes],
                "frame periods",
                f"Planner reaction on {TURN} (every obstacle, every seed)",
            ),
            "Planner reaction per obstacle (entered the view → obstacle cell on its footprint)",
        ),
    ]
