"""Sonar fusion on and off (paper §3.2, Fig. 9): on ``near-obstacle`` a thin post stands
about 1 m ahead, right of the robot's axis, inside a sonar cone, with larger textured
obstacles farther away. Without the sonars the flies may gather on the far obstacles and
neglect the post; with them, flies at the sonar's range get fitness × (1 + B) and sonar
immigrants are placed on the range arc. One generation per frame, as in the paper."""

from __future__ import annotations

import dataclasses
import math
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
    Count,
    ExperimentOptions,
    ExperimentResult,
    Table,
    experiment_dir,
    spread,
)
from flylog.experiments.markdown import finish_experiment
from flylog.experiments.runs import (
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

NAME = "sonar"
SCENE = "near-obstacle"
CONFIGS = {"with sonar fusion": True, "without sonar fusion": False}
ON_POST = 0.1  # m: an obstacle fly within this 2-D distance of the post's footprint is on it


def nearest_obstacle(scene) -> int:
    """Index of the obstacle nearest the start (the post)."""
    from flylog.scene.load import distance_to_obstacles

    start = scene.start_pose
    d = [
        distance_to_obstacles(
            dataclasses.replace(scene, obstacles=(ob,)), np.array([[start.x, start.y]])
        )[0]
        for ob in scene.obstacles
    ]
    return int(np.argmin(d))


def flies_on_obstacle(scene, obstacle: int, world_xy: np.ndarray, xyz: np.ndarray) -> int:
    """How many flies (world x, y and base_link z) lie on the obstacle: within ON_POST of its
    footprint and not above its top."""
    from flylog.scene.load import distance_to_obstacles

    if len(world_xy) == 0:
        return 0
    one = dataclasses.replace(scene, obstacles=(scene.obstacles[obstacle],))
    near = distance_to_obstacles(one, world_xy) <= ON_POST
    return int(np.sum(near & (xyz[:, 2] <= scene.obstacles[obstacle].height + ON_POST)))


def post_counts(
    scene, post: int, run: Path, log: Path
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per snapshot: time (s from the first), obstacle flies on the post, obstacle flies."""
    times, clouds = fly_snapshots(run)
    if len(times) == 0:
        return np.empty(0), np.empty(0), np.empty(0)
    poses = true_poses_at(log, times)
    on = [
        flies_on_obstacle(scene, post, to_world(xyz, pose), xyz)
        for xyz, pose in zip(clouds, poses, strict=True)
    ]
    return (times - times[0]) / 1e9, np.array(on, float), np.array([len(c) for c in clouds], float)


@dataclass(frozen=True)
class _Drawn:
    """What the figures need of seed 0, kept after its logs are deleted."""

    rig: StereoRig
    maps: tuple[plots.MapPanel, ...]
    frames: tuple[plots.FramePanel, ...]


@dataclass(frozen=True)
class _SeedResult:
    runs: tuple[dict, ...]  # one per configuration
    curves: dict[str, tuple[np.ndarray, np.ndarray]]  # t, obstacle flies on the post
    drawn: _Drawn | None  # seed 0 only


def plan_sonar(out_dir: Path, options: ExperimentOptions) -> ExperimentPlan:
    """One cell per seed; the experiment writes ``out_dir/sonar/``."""
    from flylog.scene.load import load_scene

    here = experiment_dir(out_dir, NAME)
    scene = load_scene(options.scene_path(SCENE))
    duration = options.duration_or(scene.spec.duration or 5.0)
    frame_rate = scene.spec.camera.frame_rate
    task = SeedTask(here, options, 0, duration, frame_rate)
    cells = seed_cells(NAME, SCENE, task, options.seeds, len(CONFIGS), _run_seed)

    def assemble(results: list[_SeedResult]) -> ExperimentResult:
        return _finish(here, options, scene, duration, results)

    return ExperimentPlan(NAME, cells, assemble)


def _run_seed(task: SeedTask) -> _SeedResult:
    from flylog.scene.load import load_scene

    here, options, seed = task.here, task.options, task.seed
    scene = load_scene(options.scene_path(SCENE))
    post = nearest_obstacle(scene)
    log = simulate_scene(options, SCENE, seed, here / "runs" / f"near_s{seed}.mcap", task.duration)
    runs: list[dict] = []
    curves: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    replays: list[Path] = []
    for label, on in CONFIGS.items():
        config = with_flies(
            one_generation_per_frame(
                seed, task.frame_rate, {"sonar_fitness": on, "sonar_immigration": on}
            ),
            options,
        )
        run = here / "runs" / f"near_s{seed}_{'on' if on else 'off'}.mcap"
        replays.append(run)
        scored = replay_and_score(log, run, config)
        t, on_post, total = post_counts(scene, post, run, log)
        curves[label] = (t, on_post)
        row = scored.obstacles[post]
        share = on_post / np.maximum(total, 1.0)
        runs.append(
            {
                "configuration": label,
                "seed": seed,
                "post_flies_median": float(np.median(on_post)) if len(on_post) else math.nan,
                "post_share_median": float(np.median(share)) if len(share) else math.nan,
                "post_detected": bool(math.isfinite(row["first_detected_s"])),
                "post_latency_s": row["latency_s"],
                "precision": scored.summary["precision"],
                "recall": scored.summary["recall"],
            }
        )
    drawn = _drawn(here, log, task.duration) if seed == 0 else None
    if not options.keep_logs:
        for path in (*replays, log):
            path.unlink()
    return _SeedResult(tuple(runs), curves, drawn)


def _finish(
    here: Path, options: ExperimentOptions, scene, duration: float, results: list[_SeedResult]
) -> ExperimentResult:
    post = nearest_obstacle(scene)
    runs = [run for r in results for run in r.runs]
    curves = {c: [r.curves[c] for r in results] for c in CONFIGS}
    table = _table(runs, options.seeds)
    drawn = results[0].drawn
    assert drawn is not None  # seed 0 is the first cell
    figures = _figures(here, scene, drawn, curves)
    findings = [
        f"{r['configuration']}: post detected on {r['post_detected'].k} of "
        f"{r['post_detected'].n} seeds, median {r['post_flies'].mean:.1f} obstacle flies on it"
        for r in table.rows
    ]
    setup = [
        f"scene `{SCENE}` ({duration:g} s, the robot creeps forward at 5 cm/s), "
        f"{options.resolution[0]}×{options.resolution[1]} pixels; the post is obstacle "
        f"{post}, a cylinder of radius {scene.obstacles[post].radius} m",
        "replay: one generation per frame, snapshots every frame; *with*: sonar fitness "
        "bonus (B = 0.5) and sonar-biased immigration; *without*: both off",
        f"a fly is *on the post* if it is an obstacle fly within {ON_POST} m (2-D) of the "
        "post's footprint, seen from the true pose; *detected*: the metrics' rule (5 "
        "obstacle flies on its visible surface)",
        f"{options.seeds} seeds (0…{options.seeds - 1}); mean ± standard deviation over seeds",
    ]
    return finish_experiment(
        NAME,
        here,
        options,
        title="Sonar fusion on and off (paper Fig. 9)",
        intro=__doc__ or "",
        table=table,
        findings=findings,
        figures=figures,
        setup=setup,
        runs=runs,
    )


def _table(runs: list[dict], seeds: int) -> Table:
    rows = []
    for label in CONFIGS:
        mine = [r for r in runs if r["configuration"] == label]
        rows.append(
            {
                "configuration": label,
                "post_detected": Count(sum(r["post_detected"] for r in mine), len(mine)),
                "post_latency": spread([r["post_latency_s"] for r in mine]),
                "post_flies": spread([r["post_flies_median"] for r in mine]),
                "post_share": spread([r["post_share_median"] for r in mine]),
                "precision": spread([r["precision"] for r in mine]),
                "recall": spread([r["recall"] for r in mine]),
            }
        )
    columns = (
        Column("configuration", "configuration"),
        Column("post_detected", "post detected (seeds)"),
        Column("post_latency", "post detection latency (s)", ".2f"),
        Column("post_flies", "obstacle flies on the post (median)", ".1f"),
        Column("post_share", "share of obstacle flies on the post", ".3f"),
        Column("precision", "precision"),
        Column("recall", "recall"),
    )
    return Table(f"The near post on `{SCENE}` over {seeds} seeds", columns, tuple(rows))


def _drawn(here: Path, log: Path, duration: float) -> _Drawn:
    """Seed 0's obstacle flies at 0.6 of the run, on the map and on the left frame."""
    from flylog.sources import read_truth

    rig = read_truth(log).rig
    at_ns = round(duration * 0.6e9)
    maps, frames = [], []
    for label, on in CONFIGS.items():
        times, clouds = fly_snapshots(here / "runs" / f"near_s0_{'on' if on else 'off'}.mcap")
        if not len(times):
            continue
        i = min(int(np.searchsorted(times, at_ns)), len(times) - 1)
        pose = true_poses_at(log, times[i : i + 1])[0]
        t_s = times[i] / 1e9
        maps.append(
            plots.MapPanel(
                f"{label}, t = {t_s:.1f} s",
                flies=to_world(clouds[i], pose),
                view_from=(float(pose[0]), float(pose[1]), float(pose[2])),
                extent=(-0.5, 7.0, -3.5, 3.5),
            )
        )
        _, image = left_image_at(log, int(times[i]))
        u, _, v, _ = rig.project(clouds[i]) if len(clouds[i]) else (np.empty(0),) * 4
        ok = (u >= 0) & (u < rig.width) & (v >= 0) & (v < rig.height)
        frames.append(plots.FramePanel(f"{label}, t = {t_s:.1f} s", image, np.c_[u[ok], v[ok]]))
    return _Drawn(rig, tuple(maps), tuple(frames))


def _figures(
    here: Path,
    scene,
    drawn: _Drawn,
    curves: dict[str, list[tuple[np.ndarray, np.ndarray]]],
) -> list[tuple[Path, str]]:
    rig, maps, frames = drawn.rig, list(drawn.maps), list(drawn.frames)
    out: list[tuple[Path, str]] = []
    if maps:
        out.append(
            (
                plots.map_figure(here / "map.png", scene, maps, rig=rig),
                "Top-down (seed 0): obstacle flies with (left) and without (right) sonar "
                "fusion; red lines: the cameras' field of view (paper Fig. 9)",
            )
        )
        out.append(
            (
                plots.frames_figure(here / "frames.png", frames),
                "The left frame at the same instant with the obstacle flies in red",
            )
        )
    out.append(
        (
            plots.curves_figure(
                here / "curves.png",
                [
                    (
                        "obstacle flies on the post",
                        [plots.Curve(c, tuple(curves[c])) for c in curves],
                    )
                ],
                title="Obstacle flies on the near post (thin: seeds; bold: mean)",
            ),
            "Obstacle flies on the near post over time, with and without sonar fusion",
        )
    )
    return out
