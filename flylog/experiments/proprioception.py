"""Proprioception on and off (paper §3.4, Fig. 4/5): the robot turns 1° right per frame on
``turn``, one generation per frame; with proprioception the engine moves every fly by the
inverse of the odometric motion, without it the flies must re-converge after each turn."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flylog.experiments import plots
from flylog.experiments.cells import (
    ExperimentPlan,
    SeedTask,
    seed_cells,
)
from flylog.experiments.common import (
    Column,
    ExperimentOptions,
    ExperimentResult,
    Table,
    experiment_dir,
    spread,
)
from flylog.experiments.markdown import finish_experiment
from flylog.experiments.runs import (
    ScoredRun,
    fly_snapshots,
    left_image_at,
    one_generation_per_frame,
    replay_and_score,
    simulate_scene,
    to_world,
    true_poses_at,
    with_flies,
)
from flylog.geometry import StereoRig

NAME = "proprioception"
SCENE = "turn"
FRAME_STEP = 5  # frames N and N + 5, as the paper's figures
CONFIGS = {"with proprioception": True, "without proprioception": False}


@dataclass(frozen=True)
class _Drawn:
    """What the figures need of seed 0, kept after its logs are deleted."""

    rig: StereoRig
    frame: int  # frame N
    frames: tuple[plots.FramePanel, ...]
    maps: tuple[plots.MapPanel, ...]


@dataclass(frozen=True)
class _SeedResult:
    runs: tuple[dict, ...]  # one per configuration
    curves: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]  # t, precision, recall
    drawn: _Drawn | None  # seed 0 only


def plan_proprioception(out_dir: Path, options: ExperimentOptions) -> ExperimentPlan:
    """One cell per seed; the experiment writes ``out_dir/proprioception/``."""
    from flylog.scene.load import load_scene

    here = experiment_dir(out_dir, NAME)
    scene = load_scene(options.scene_path(SCENE))
    duration = options.duration_or(scene.spec.duration or 8.0)
    frame_rate = scene.spec.camera.frame_rate
    task = SeedTask(here, options, 0, duration, frame_rate)
    cells = seed_cells(NAME, SCENE, task, options.seeds, len(CONFIGS), _run_seed)

    def assemble(results: list[_SeedResult]) -> ExperimentResult:
        return _finish(here, options, scene, duration, frame_rate, results)

    return ExperimentPlan(NAME, cells, assemble)


def _run_seed(task: SeedTask) -> _SeedResult:
    here, options, seed = task.here, task.options, task.seed
    log = simulate_scene(options, SCENE, seed, here / "runs" / f"turn_s{seed}.mcap", task.duration)
    runs: list[dict] = []
    curves: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    first: dict[str, ScoredRun] = {}
    for label, on in CONFIGS.items():
        config = with_flies(
            one_generation_per_frame(seed, task.frame_rate, {"proprioception": on}), options
        )
        tag = "on" if on else "off"
        scored = replay_and_score(log, here / "runs" / f"turn_s{seed}_{tag}.mcap", config)
        s = scored.summary
        runs.append({"configuration": label, "seed": seed, **{k: s[k] for k in _SUMMARY_KEYS}})
        curves[label] = (
            np.array([r["t_s"] for r in scored.snapshots]),
            np.array([r["precision"] for r in scored.snapshots]),
            np.array([r["recall"] for r in scored.snapshots]),
        )
        first[label] = scored
    drawn = _drawn(first, log, task.duration, task.frame_rate) if seed == 0 else None
    if not options.keep_logs:
        for scored in first.values():
            scored.run.unlink()
        log.unlink()
    return _SeedResult(tuple(runs), curves, drawn)


def _finish(
    here: Path,
    options: ExperimentOptions,
    scene,
    duration: float,
    frame_rate: float,
    results: list[_SeedResult],
) -> ExperimentResult:
    runs = [run for r in results for run in r.runs]
    curves = {c: [r.curves[c] for r in results] for c in CONFIGS}
    table = _table(runs, options.seeds)
    drawn = results[0].drawn
    assert drawn is not None  # seed 0 is the first cell
    figures = _figures(here, scene, drawn, curves)
    findings = _findings(table)
    setup = [
        f"scene `{SCENE}` ({duration:g} s, the robot turns 1° right per frame at "
        f"{frame_rate:g} Hz), {options.resolution[0]}×{options.resolution[1]} pixels",
        "replay: one generation per frame (`generations_per_frame = 1`), snapshots every "
        "frame, engine defaults otherwise"
        + (f" with {options.flies} flies" if options.flies else " (5000 flies)"),
        f"{options.seeds} seeds (0…{options.seeds - 1}): each seed simulates its own log "
        "(trajectory and sonar noise) and seeds the engine",
        "metrics: `flylog metrics` definitions (obstacle flies, τ = 0.05), pooled over the "
        "snapshots of a run; the table gives mean ± standard deviation over seeds",
    ]
    return finish_experiment(
        NAME,
        here,
        options,
        title="Proprioception on and off (paper Fig. 4/5)",
        intro=__doc__ or "",
        table=table,
        findings=findings,
        figures=figures,
        setup=setup,
        runs=runs,
    )


_SUMMARY_KEYS = (
    "precision",
    "recall",
    "f_score",
    "median_depth_error",
    "obstacles_visible",
    "obstacles_detected",
    "detection_latency_mean_s",
)


def _table(runs: list[dict], seeds: int) -> Table:
    rows = []
    for label in CONFIGS:
        mine = [r for r in runs if r["configuration"] == label]
        rows.append(
            {
                "configuration": label,
                "seeds": len(mine),
                **{k: spread([r[k] for r in mine]) for k in _SUMMARY_KEYS},
            }
        )
    columns = (
        Column("configuration", "configuration"),
        Column("seeds", "seeds"),
        Column("precision", "precision"),
        Column("recall", "recall"),
        Column("f_score", "F"),
        Column("median_depth_error", "median depth error"),
        Column("obstacles_detected", "obstacles detected", ".1f"),
        Column("detection_latency_mean_s", "detection latency (s)", ".2f"),
    )
    return Table(f"Fly metrics on `{SCENE}` over {seeds} seeds", columns, tuple(rows))


def _findings(table: Table) -> list[str]:
    on, off = table.rows
    out = []
    for key, what in (("precision", "precision"), ("recall", "recall")):
        a, b = on[key], off[key]
        out.append(
            f"{what}: {a.mean:.3f} with proprioception, {b.mean:.3f} without "
            f"(difference {a.mean - b.mean:+.3f}, over {a.n} seeds)"
        )
    return out


def _drawn(first: dict[str, ScoredRun], log: Path, duration: float, frame_rate: float) -> _Drawn:
    """Seed 0's frames N and N + FRAME_STEP with the obstacle flies, and its map panels."""
    from flylog.sources import read_truth

    rig = read_truth(log).rig
    period_ns = 1e9 / frame_rate
    n = max(0, int(duration * frame_rate / 2) - FRAME_STEP // 2)  # frame N, mid-run
    frames, maps = [], []
    for label, scored in first.items():
        times, clouds = fly_snapshots(scored.run)
        for k in (n, n + FRAME_STEP):
            stamp, image = left_image_at(log, round(k * period_ns))
            uv = np.empty((0, 2))
            if len(times):
                i = min(int(np.searchsorted(times, stamp)), len(times) - 1)
                xyz = clouds[i]
                if len(xyz):
                    u, _, v, _ = rig.project(xyz)
                    ok = (u >= 0) & (u < rig.width) & (v >= 0) & (v < rig.height)
                    uv = np.stack([u[ok], v[ok]], axis=1)
            frames.append(plots.FramePanel(f"{label}: frame {k}", image, uv))
        if len(times):
            i = min(int(np.searchsorted(times, round(n * period_ns))), len(times) - 1)
            pose = true_poses_at(log, times[i : i + 1])[0]
            maps.append(
                plots.MapPanel(
                    f"{label}, frame {n}",
                    flies=to_world(clouds[i], pose),
                    view_from=(float(pose[0]), float(pose[1]), float(pose[2])),
                    extent=(-1.0, 7.0, -4.5, 3.5),
                )
            )
    return _Drawn(rig, n, tuple(frames), tuple(maps))


def _figures(
    here: Path,
    scene,
    drawn: _Drawn,
    curves: dict[str, list[tuple[np.ndarray, np.ndarray, np.ndarray]]],
) -> list[tuple[Path, str]]:
    rig, n, frames, maps = drawn.rig, drawn.frame, list(drawn.frames), list(drawn.maps)
    out = [
        (
            plots.frames_figure(here / "frames.png", frames),
            f"Left frames N and N+{FRAME_STEP} (seed 0) with the obstacle flies in red: "
            "with proprioception (top) and without (bottom)",
        ),
        (
            plots.curves_figure(
                here / "curves.png",
                [
                    (
                        "precision",
                        [plots.Curve(c, tuple((t, p) for t, p, _ in curves[c])) for c in curves],
                    ),
                    (
                        "recall",
                        [plots.Curve(c, tuple((t, r) for t, _, r in curves[c])) for c in curves],
                    ),
                ],
                title="Obstacle-fly precision and recall per snapshot (thin: seeds; bold: mean)",
            ),
            "Precision and recall over time, with and without proprioception",
        ),
    ]
    if maps:
        out.append(
            (
                plots.map_figure(here / "map.png", scene, maps, rig=rig),
                f"Top-down: the obstacle flies of frame {n} (seed 0) on the true map, "
                "the cameras' field of view in red",
            )
        )
    return out
