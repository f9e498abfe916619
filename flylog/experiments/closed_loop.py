"""Closed-loop obstacle avoidance (paper §4, Fig. 7/8): the fly engine and the harmonic
planner drive the simulated robot from start to goal on ``corridor``, ``clutter`` and
``doorways`` (``flylog simulate --drive planner``), and ``doorways`` at twice the
resolution (640×480 beside 320×240). A run *succeeds* if the true position reaches the
goal without any collision (the robot's footprint never enters an obstacle's)."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from flylog.config import replace_dotted
from flylog.experiments.cells import ExperimentCell, ExperimentPlan, log_seconds_work
from flylog.experiments.closed_loop_plots import Drawn, figures, seed0_flies
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
from flylog.experiments.runs import score, simulate_scene, trajectories, with_flies
from flylog.planner import PlannerConfig
from flylog.replay.config import ReplayConfig

NAME = "closed-loop"
SCENES = ("corridor", "clutter", "doorways")
# (scene, resolution factor, seeds at most) run besides: the narrow passages at twice the
# resolution (640×480 beside 320×240), where one pixel of disparity spans half the depth
FINER = (("doorways", 2, 3),)
# A time limit, not a duration: a run ends when the planner reports the goal reached, or
# STUCK for planner.stuck_timeout. The scenes' own durations suit their scripted drives,
# not the planner's slower, winding paths: a round of clutter outside its walls (44 m)
# takes 121 s.
TIME_LIMIT = 180.0  # s


@dataclasses.dataclass(frozen=True)
class _Job:
    group: str  # the table row: the scene, or the scene and a resolution
    scene: str
    seed: int
    resolution: tuple[int, int]


def _jobs(options: ExperimentOptions) -> list[_Job]:
    jobs = [_Job(s, s, k, options.resolution) for s in SCENES for k in range(options.seeds)]
    for scene, factor, most in FINER:
        w, h = (factor * n for n in options.resolution)
        group = f"{scene} {w}×{h}"
        jobs += [_Job(group, scene, k, (w, h)) for k in range(min(most, options.seeds))]
    return jobs


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


@dataclasses.dataclass(frozen=True)
class _Cell:
    here: Path
    options: ExperimentOptions
    overrides: Mapping[str, object]
    job: _Job


def plan_closed_loop(
    out_dir: Path, options: ExperimentOptions, *, planner: Mapping[str, object] | None = None
) -> ExperimentPlan:
    """One cell per scene (and resolution) and seed; the experiment writes
    ``out_dir/closed-loop/``.

    ``planner``: overrides of the planner's defaults (``{"obstacle_weight": 1.0}``: the
    paper's Dirichlet obstacles), applied to every run and listed in the set-up."""
    from flylog.scene.load import load_scene

    here = experiment_dir(out_dir, NAME)
    overrides = {f"planner.{key}": value for key, value in (planner or {}).items()}
    jobs = _jobs(options)
    scenes = {name: load_scene(options.scene_path(name)) for name in SCENES}
    limit = options.duration_or(TIME_LIMIT)
    base_pixels = options.resolution[0] * options.resolution[1]
    cells = tuple(
        ExperimentCell(
            NAME,
            f"{job.group}, seed {job.seed}",
            # the time limit bounds the loop; the engine runs as the robot is simulated
            log_seconds_work(
                limit, 1, pixel_scale=job.resolution[0] * job.resolution[1] / base_pixels
            ),
            _run_cell,
            _Cell(here, options, overrides, job),
        )
        for job in jobs
    )

    def assemble(results: list[tuple[dict, Drawn]]) -> ExperimentResult:
        return _finish(here, options, overrides, scenes, jobs, results)

    return ExperimentPlan(NAME, cells, assemble)


def run_closed_loop(
    out_dir: Path, options: ExperimentOptions, *, planner: Mapping[str, object] | None = None
) -> ExperimentResult:
    """The experiment with ``planner`` overrides (see :func:`plan_closed_loop`), its cells
    one after the other in this process."""
    from flylog.experiments.parallel import run_plans_serially

    return run_plans_serially([plan_closed_loop(out_dir, options, planner=planner)])[0]


def _run_cell(cell: _Cell) -> tuple[dict, Drawn]:
    return _one_run(cell.here, cell.options, cell.overrides, cell.job)


def _finish(
    here: Path,
    options: ExperimentOptions,
    overrides: Mapping[str, object],
    scenes: dict,
    jobs: list[_Job],
    results: list[tuple[dict, Drawn]],
) -> ExperimentResult:
    runs = [row for row, _ in results]
    groups = {job.group: job.scene for job in jobs}
    drawn = {
        g: [d for job, (_, d) in zip(jobs, results, strict=True) if job.group == g] for g in groups
    }
    effective = _config(options, 0, overrides)
    used, heading = effective.planner, effective.heading
    table = _table(runs, groups, options.seeds)
    drawings = figures(here, scenes, drawn, groups)
    findings = _findings(runs, table)
    wide = [g for g in groups if g not in SCENES]
    setup = [
        f"scenes {', '.join(f'`{s}`' for s in SCENES)} at {options.resolution[0]}×"
        f"{options.resolution[1]} pixels, closed loop (`flylog simulate --drive planner`), "
        "asynchronous engine and planner with the defaults"
        + (f", {options.flies} flies" if options.flies else " (5000 flies)")
        + (f"; besides, {', '.join(f'`{g}`' for g in wide)}" if wide else ""),
        "each run ends when the planner reports the goal reached, when it has reported "
        f"STUCK for {used.stuck_timeout:g} s (planner.stuck_timeout), or after "
        f"{options.duration_or(TIME_LIMIT):g} s",
        f"{options.seeds} seeds per scene (0…{options.seeds - 1}; "
        + ", ".join(f"{g}: {len(drawn[g])}" for g in wide)
        + "): the seed drives the trajectory and sonar noise and the engine; mean ± "
        "standard deviation over seeds; *inside the walls*: the true path never leaves the "
        "bounding box of the scene's walls (on `clutter`: through the clutter, not round "
        "the outside of its walls)",
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
        figures=drawings,
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
        + (
            f"; every sonar's cone up to its echo (its maximum range without one) less "
            f"{planner.sonar_free_margin:g} m counts as seen free"
            if planner.sonar_clears
            else ""
        )
        + f"; remembered obstacle cells within {planner.clear_min_range:g} m are never "
        "cleared as seen free; the obstacle-free field is relaxed before the first tick "
        f"(at most {planner.warm_start_sweeps} sweeps), then each tick relaxes "
        f"until a sweep changes U by at most {planner.relax_tolerance:g} (at most "
        f"{planner.max_sweeps_per_tick} sweeps); grid {planner.extent:g} m a side, centred "
        "between start and goal" + (f" (overridden here: {changed})" if changed else "")
    )


def _one_run(
    here: Path, options: ExperimentOptions, overrides: Mapping[str, object], job: _Job
) -> tuple[dict, Drawn]:
    """Simulate one closed-loop run of ``job``, score it; its row and what the figures need
    (the log is deleted unless kept)."""
    from flylog.io import contract
    from flylog.io.reader import open_log
    from flylog.scene.load import load_scene

    name, seed = job.scene, job.seed
    scene = load_scene(options.scene_path(name))
    config = _config(options, seed, overrides)
    w, h = job.resolution
    log = here / "runs" / f"{name}_{w}x{h}_s{seed}.mcap"
    at = dataclasses.replace(options, resolution=job.resolution)
    simulate_scene(at, name, seed, log, options.duration_or(TIME_LIMIT), drive_with=config)
    ending = open_log(log).metadata()[contract.REPLAY_METADATA].get("ending", "")
    scored = score(log, log)
    s = scored.summary
    t, true, odom = trajectories(log)
    touched = touched_obstacles(scene, true[:, :2], scene.spec.robot.radius)
    row = {
        "scene": job.group,
        "seed": seed,
        "success": bool(s["goal_reached"] and s["collisions"] == 0),
        **{k: s[k] for k in _SUMMARY_KEYS},
        "touched": [describe_obstacle(scene, k) for k in touched],
        # what the robot cannot know: how far its odometry is off at the end
        "final_drift_m": float(np.hypot(*(true[-1, :2] - odom[-1, :2]))),
        "ending": ending,
        "inside_walls": inside_walls(scene, true[:, :2]),
    }
    rows = scored.snapshots
    drawn = Drawn(
        seed,
        t,
        true[:, :2],
        odom[:, :2],
        np.array([r["t_s"] for r in rows]),
        np.array([r["nearest_true_m"] for r in rows]) - scene.spec.robot.radius,
        seed0_flies(log) if seed == 0 else None,
    )
    if not options.keep_logs:
        log.unlink()
    return row, drawn


def inside_walls(scene, xy: np.ndarray) -> bool:
    """Whether the points (N, 2) all lie inside the bounding box of the scene's walls (True
    for a scene without walls)."""
    ends = [p for ob in scene.obstacles if ob.kind.value == "wall" for p in (ob.start, ob.end)]
    if not ends:
        return True
    lo, hi = np.min(ends, axis=0), np.max(ends, axis=0)
    return bool(np.all((xy >= lo) & (xy <= hi)))


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


def _table(runs: list[dict], groups: Mapping[str, str], seeds: int) -> Table:
    rows = []
    for name in groups:
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
                "inside_walls": Count(sum(r["inside_walls"] for r in mine), len(mine)),
                "stuck": Count(sum(r["ending"] == "stuck" for r in mine), len(mine)),
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
        Column("inside_walls", "inside the walls"),
        Column("stuck", "ended STUCK"),
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
        mine = [r for r in runs if r["scene"] == row["scene"]]
        lengths = [r["path_length_m"] for r in mine]
        clear = min((r["min_clearance_m"] for r in mine), default=float("nan"))
        out.append(
            f"`{row['scene']}`: goal reached without collision on {row['success'].k} of "
            f"{row['success'].n} seeds (goal reached on {row['goal_reached'].k}, no collision "
            f"on {row['collision_free'].k}, ended STUCK on {row['stuck'].k}); inside the walls "
            f"on {row['inside_walls'].k}; path length {min(lengths):.1f}–{max(lengths):.1f} m; "
            f"lowest minimum clearance {clear:.2f} m"
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
            ended = f"; ended {r['ending']}" if r["ending"] else ""
            out.append(
                f"`{r['scene']}` seed {r['seed']}: goal {goal}{ended}; touched {what}; "
                f"min clearance {r['min_clearance_m']:.2f} m; odometric drift at the end "
                f"{r['final_drift_m']:.2f} m"
            )
    return out
