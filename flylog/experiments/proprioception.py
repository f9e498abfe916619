"""Proprioception on and off (paper §3.4, Fig. 4/5): the robot turns 1° right per frame on
``turn``, one generation per frame; with proprioception the engine moves every fly by the
inverse of the odometric motion, without it the flies must re-converge after each turn."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from flylog.experiments import plots
from flylog.experiments.common import (
    Column,
    ExperimentOptions,
    ExperimentResult,
    Progress,
    Steps,
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

NAME = "proprioception"
SCENE = "turn"
FRAME_STEP = 5  # frames N and N + 5, as the paper's figures
CONFIGS = {"with proprioception": True, "without proprioception": False}


def run_proprioception(
    out_dir: Path, options: ExperimentOptions, *, on_progress: Progress | None = None
) -> ExperimentResult:
    """Run the experiment over ``options.seeds`` seeds; write ``out_dir/proprioception/``."""
    from flylog.scene.load import load_scene

    here = experiment_dir(out_dir, NAME)
    scene = load_scene(options.scene_path(SCENE))
    duration = options.duration_or(scene.spec.duration or 8.0)
    frame_rate = scene.spec.camera.frame_rate
    steps = Steps(options.seeds * (1 + len(CONFIGS)), on_progress)
    runs: list[dict] = []
    first: dict[str, ScoredRun] = {}
    curves: dict[str, list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {c: [] for c in CONFIGS}
    for seed in range(options.seeds):
        log = simulate_scene(options, SCENE, seed, here / "runs" / f"turn_s{seed}.mcap", duration)
        steps.step()
        for label, on in CONFIGS.items():
            config = with_flies(
                one_generation_per_frame(seed, frame_rate, {"proprioception": on}), options
            )
            tag = "on" if on else "off"
            scored = replay_and_score(log, here / "runs" / f"turn_s{seed}_{tag}.mcap", config)
            s = scored.summary
            runs.append(
                {
                    "configuration": label,
                    "seed": seed,
                    **{k: s[k] for k in _SUMMARY_KEYS},
                }
            )
            t = np.array([r["t_s"] for r in scored.snapshots])
            curves[label].append(
                (
                    t,
                    np.array([r["precision"] for r in scored.snapshots]),
                    np.array([r["recall"] for r in scored.snapshots]),
                )
            )
            if seed == 0:
                first[label] = scored
            steps.step()
    table = _table(runs, options.seeds)
    log0 = here / "runs" / "turn_s0.mcap"
    figures = _figures(here, scene, first, log0, duration, frame_rate, curves)
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


def _figures(
    here: Path,
    scene,
    first: dict[str, ScoredRun],
    log: Path,
    duration: float,
    frame_rate: float,
    curves: dict[str, list[tuple[np.ndarray, np.ndarray, np.ndarray]]],
) -> list[tuple[Path, str]]:
    from flylog.metrics.truth import read_truth

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
