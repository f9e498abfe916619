"""Closed-loop obstacle avoidance (paper §4, Fig. 7/8): the fly engine and the harmonic
planner drive the simulated robot from start to goal on ``corridor`` and ``clutter``
(``flylog simulate --drive planner``). A run *succeeds* if the true position reaches the
goal without any collision (the robot's footprint never enters an obstacle's)."""

from __future__ import annotations

import dataclasses
import multiprocessing
import os
from collections.abc import Mapping
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from flylog.config import replace_dotted
from flylog.experiments import plots
from flylog.experiments.common import (
    Column,
    Count,
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
    fly_snapshots,
    score,
    simulate_scene,
    to_world,
    trajectories,
    true_poses_at,
    with_flies,
)
from flylog.planner import PlannerConfig
from flylog.replay.config import ReplayConfig

NAME = "closed-loop"
SCENES = ("corridor", "clutter")
MAX_FLIES_DRAWN = 4000  # obstacle flies of seed 0 on the map, subsampled evenly
# A time limit, not a duration: a run ends when the planner reports the goal reached. The
# scenes' own durations (30 s, 40 s) suit their scripted drives, not the planner's slower,
# winding paths: clutter's round outside its walls takes 92-104 s, and clutter seed 18's
# 44 m one 120.8 s (a 120 s limit ends it 0.39 m short, still driving).
TIME_LIMIT = 180.0  # s


@dataclasses.dataclass(frozen=True)
class _Drawn:
    """What the figures need of one run, kept after its log is deleted."""

    seed: int
    t: np.ndarray  # s
    true_xy: np.ndarray
    odom_xy: np.ndarray
    clearance_t: np.ndarray
    clearance: np.ndarray
    flies: np.ndarray | None  # world x, y of the obstacle flies (seed 0 only)


def touched_obstacles(scene, xy: np.ndarray, radius: float) -> list[int]:
    """Indices of the obstacles the robot's footprint (disc of ``radius`` at each of the
    true positions ``xy``) entered."""
    from flylog.scene.load import distance_to_obstacles

    out = []
    for k, ob in enumerate(scene.obstacles):
        one = dataclasses.replace(scene, obstacles=(ob,))
        if np.any(distance_to_obstacles(one, xy) < radius):
            out.append(k)
    return out


def describe_obstacle(scene, k: int) -> str:
    ob = scene.obstacles[k]
    where = ob.center if ob.center is not None else ob.start
    what = ob.kind.value + (", untextured" if ob.low_texture else "")
    what += ", sonar-absorbing" if ob.sonar_absorbing else ""
    return f"#{k} ({what}, at x = {where[0]:.1f}, y = {where[1]:.1f})"


def run_closed_loop(
    out_dir: Path,
    options: ExperimentOptions,
    *,
    on_progress: Progress | None = None,
    planner: Mapping[str, object] | None = None,
) -> ExperimentResult:
    """Drive ``options.seeds`` runs on each scene; write ``out_dir/closed-loop/``.

    ``planner``: overrides of the planner's defaults (``{"obstacle_weight": 1.0}``: the
    paper's Dirichlet obstacles), applied to every run and listed in the set-up."""
    from flylog.scene.load import load_scene

    here = experiment_dir(out_dir, NAME)
    overrides = {f"planner.{key}": value for key, value in (planner or {}).items()}
    steps = Steps(options.seeds * len(SCENES), on_progress)
    scenes = {name: load_scene(options.scene_path(name)) for name in SCENES}
    jobs = [(name, seed) for name in SCENES for seed in range(options.seeds)]
    done: dict[tuple[str, int], tuple[dict, _Drawn]] = {}
    # every run is independent and seeded: run them side by side, one per core
    workers = min(len(jobs), os.cpu_count() or 1)
    if workers > 1:
        # spawn, not fork: a forked child inherits the parent's threads' locks (pytest, I/O)
        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
            futures = {pool.submit(_one_run, here, options, overrides, *job): job for job in jobs}
            for future in as_completed(futures):
                done[futures[future]] = future.result()
                steps.step()
    else:
        for job in jobs:
            done[job] = _one_run(here, options, overrides, *job)
            steps.step()
    runs = [done[job][0] for job in jobs]
    drawn: dict[str, list[_Drawn]] = {
        s: [done[(s, k)][1] for k in range(options.seeds)] for s in SCENES
    }
    effective = _config(options, 0, overrides)
    used, heading = effective.planner, effective.heading
    table = _table(runs, options.seeds)
    figures = _figures(here, scenes, drawn)
    findings = _findings(runs, table)
    setup = [
        f"scenes {', '.join(f'`{s}`' for s in SCENES)} at {options.resolution[0]}×"
        f"{options.resolution[1]} pixels, closed loop (`flylog simulate --drive planner`), "
        "asynchronous engine and planner with the defaults"
        + (f", {options.flies} flies" if options.flies else " (5000 flies)"),
        "each run ends when the planner reports the goal reached, or after "
        f"{options.duration_or(TIME_LIMIT):g} s",
        f"{options.seeds} seeds per scene (0…{options.seeds - 1}): the seed drives the "
        "trajectory and sonar noise and the engine; mean ± standard deviation over seeds",
        "goal reached: the true position within 0.2 m of the goal (metrics.goal_tolerance); "
        "the planner stops when its own position is within "
        f"{used.goal_tolerance:g} m of the goal (planner.goal_tolerance): the odometry, its "
        "heading corrected by the flies"
        + (" ([heading], on)" if heading.enabled else " (the correction is off here)")
        + ", so the true distance to the goal at the end is about that position's error; "
        "the odometric drift at the end is how far the odometry alone was off; collisions: "
        "entries of the robot's disc into an obstacle's footprint (true trajectory)",
        _describe_planner(used, overrides),
    ]
    return finish_experiment(
        NAME,
        here,
        options,
        title="Closed-loop obstacle avoidance (paper Fig. 7/8)",
        intro=__doc__ or "",
        table=table,
        findings=findings,
        figures=figures,
        setup=setup,
        runs=runs,
    )


def _config(options: ExperimentOptions, seed: int, overrides: Mapping[str, object]):
    return replace_dotted(with_flies(ReplayConfig(seed=seed), options), overrides)


def _describe_planner(planner: PlannerConfig, overrides: Mapping[str, object]) -> str:
    if planner.obstacle_weight == 1.0:
        field = "Dirichlet obstacles (obstacle_weight 1, the paper's form)"
    else:
        field = (
            f"obstacles weighted {planner.obstacle_weight:g} among a free cell's neighbours "
            "(a Robin boundary; 1 would be the paper's Dirichlet obstacles)"
        )
    steer = (
        f"steers at the point {planner.lookahead:g} m down the descent path"
        if planner.lookahead > 0
        else "steers along −∇U at the robot"
    )
    if planner.heading_smoothing > 0:
        steer += f" (direction low-passed, time constant {planner.heading_smoothing:g} s)"
    changed = ", ".join(f"{k} = {v}" for k, v in overrides.items())
    return (
        f"planner: U = 1 on the border, 0 at the goal, {field}; obstacles inflated by "
        f"robot_radius {planner.robot_radius:g} m + inflation_margin "
        f"{planner.inflation_margin:g} m; {steer}, at most {planner.max_angular_speed:g} "
        f"rad/s; forward speed scaled down within {planner.obstacle_slowdown:g} m of "
        f"clearance (not below {planner.min_speed_fraction:g} of the maximum) and within "
        f"{planner.goal_slowdown:g} m of the goal; turns in place beyond a heading error of "
        f"{planner.turn_in_place_deg:g}°; sonar echoes nearer than {planner.sonar_range:g} m "
        "mark their arcs as obstacles at once"
        + ("" if planner.sonar_range > 0 else " (off)")
        + f"; remembered obstacle cells within {planner.clear_min_range:g} m are never "
        "cleared as seen free; the obstacle-free field is relaxed before the first tick "
        f"(at most {planner.warm_start_sweeps} sweeps), then each tick relaxes "
        f"until a sweep changes U by at most {planner.relax_tolerance:g} (at most "
        f"{planner.max_sweeps_per_tick} sweeps); grid {planner.extent:g} m a side, centred "
        "between start and goal" + (f" (overridden here: {changed})" if changed else "")
    )


def _one_run(
    here: Path, options: ExperimentOptions, overrides: Mapping[str, object], name: str, seed: int
) -> tuple[dict, _Drawn]:
    """Simulate one closed-loop run of ``name`` with ``seed``, score it; its row and what the
    figures need (the log is deleted unless kept)."""
    from flylog.scene.load import load_scene

    scene = load_scene(options.scene_path(name))
    config = _config(options, seed, overrides)
    log = here / "runs" / f"{name}_s{seed}.mcap"
    simulate_scene(options, name, seed, log, options.duration_or(TIME_LIMIT), drive_with=config)
    scored = score(log, log)
    s = scored.summary
    t, true, odom = trajectories(log)
    touched = touched_obstacles(scene, true[:, :2], scene.spec.robot.radius)
    row = {
        "scene": name,
        "seed": seed,
        "success": bool(s["goal_reached"] and s["collisions"] == 0),
        **{k: s[k] for k in _SUMMARY_KEYS},
        "touched": [describe_obstacle(scene, k) for k in touched],
        # what the robot cannot know: how far its odometry is off at the end
        "final_drift_m": float(np.hypot(*(true[-1, :2] - odom[-1, :2]))),
    }
    rows = scored.snapshots
    drawn = _Drawn(
        seed,
        t,
        true[:, :2],
        odom[:, :2],
        np.array([r["t_s"] for r in rows]),
        np.array([r["nearest_true_m"] for r in rows]) - scene.spec.robot.radius,
        _seed0_flies(log) if seed == 0 else None,
    )
    if not options.keep_logs:
        log.unlink()
    return row, drawn


_SUMMARY_KEYS = (
    "goal_reached",
    "planner_goal_reached",
    "collisions",
    "time_to_goal_s",
    "final_goal_distance_m",
    "path_length_m",
    "min_clearance_m",
    "ate_m",
    "precision",
    "recall",
)


def _seed0_flies(log: Path) -> np.ndarray:
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


def _table(runs: list[dict], seeds: int) -> Table:
    rows = []
    for name in SCENES:
        mine = [r for r in runs if r["scene"] == name]
        rows.append(
            {
                "scene": name,
                "success": Count(sum(r["success"] for r in mine), len(mine)),
                "goal_reached": Count(sum(bool(r["goal_reached"]) for r in mine), len(mine)),
                "planner_goal": Count(
                    sum(bool(r["planner_goal_reached"]) for r in mine), len(mine)
                ),
                "collision_free": Count(sum(r["collisions"] == 0 for r in mine), len(mine)),
                **{
                    k: spread([r[k] for r in mine])
                    for k in (
                        "time_to_goal_s",
                        "path_length_m",
                        "min_clearance_m",
                        "ate_m",
                        "final_goal_distance_m",
                        "final_drift_m",
                        "precision",
                        "recall",
                    )
                },
            }
        )
    columns = (
        Column("scene", "scene"),
        Column("success", "success (goal, no collision)"),
        Column("goal_reached", "goal reached"),
        Column("planner_goal", "planner reported the goal"),
        Column("collision_free", "no collision"),
        Column("time_to_goal_s", "time to goal (s)", ".1f"),
        Column("path_length_m", "path length (m)", ".2f"),
        Column("min_clearance_m", "min clearance (m)", ".2f"),
        Column("ate_m", "odometry ATE (m)", ".3f"),
        Column("final_goal_distance_m", "true distance to the goal at the end (m)", ".3f"),
        Column("final_drift_m", "odometric drift at the end (m)", ".3f"),
        Column("precision", "fly precision"),
        Column("recall", "fly recall"),
    )
    return Table(f"Closed loop over {seeds} seeds per scene", columns, tuple(rows))


def _findings(runs: list[dict], table: Table) -> list[str]:
    out = []
    for row in table.rows:
        out.append(
            f"`{row['scene']}`: goal reached without collision on {row['success'].k} of "
            f"{row['success'].n} seeds (goal reached on {row['goal_reached'].k}, no collision "
            f"on {row['collision_free'].k})"
        )
    for r in runs:
        if r["touched"] or not r["goal_reached"]:
            what = ", ".join(r["touched"]) if r["touched"] else "nothing"
            said = "; the planner reported it reached" if r["planner_goal_reached"] else ""
            goal = (
                "reached"
                if r["goal_reached"]
                else f"NOT reached ({r['final_goal_distance_m']:.2f} m short{said})"
            )
            out.append(
                f"`{r['scene']}` seed {r['seed']}: goal {goal}; touched {what}; "
                f"min clearance {r['min_clearance_m']:.2f} m; odometric drift at the end "
                f"{r['final_drift_m']:.2f} m"
            )
    return out


def _figures(here: Path, scenes: dict, drawn: dict[str, list[_Drawn]]) -> list[tuple[Path, str]]:
    panels = []
    for name, scene in scenes.items():
        paths: list[plots.Path2D] = []
        for d in drawn[name]:
            paths.append(plots.Path2D(d.true_xy, "true", "tab:green"))
            paths.append(plots.Path2D(d.odom_xy, "odometric", "tab:orange", "--", 1.0))
        flies = next((d.flies for d in drawn[name] if d.flies is not None), None)
        panels.append((name, scene, paths, flies))
    out = []
    for name, scene, paths, flies in panels:
        out.append(
            (
                plots.map_figure(
                    here / f"{name}.png",
                    scene,
                    [
                        plots.MapPanel(
                            f"{name}: {len(drawn[name])} seeds",
                            paths=tuple(paths),
                            flies=flies,
                            flies_label="obstacle flies (seed 0)",
                        )
                    ],
                ),
                f"`{name}`: true (green) and odometric (orange, dashed) trajectories of every "
                "seed; purple: the obstacle flies of seed 0 over the run (paper Fig. 7/8); "
                "hatched: untextured, dashed outline: sonar-absorbing",
            )
        )
    curve_panels = []
    for name in scenes:
        curve_panels.append(
            (
                f"{name}: clearance (m)",
                [plots.Curve(name, tuple((d.clearance_t, d.clearance) for d in drawn[name]))],
            )
        )
    drift = [
        plots.Curve(
            name,
            tuple((d.t, np.hypot(*(d.true_xy - d.odom_xy).T)) for d in drawn[name]),
        )
        for name in scenes
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
