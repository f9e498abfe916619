"""Navigation on generated worlds (BARN's discipline, Perille et al. 2020): worlds of the
``passages``, ``clutter`` and ``dead-end`` families (``flylog scene generate``) that no
setting was tuned on, one closed-loop run each. A run *succeeds* on a reachable world if
the true position reaches the goal without any collision; on a ``dead-end`` world if the
run ends ``unreachable`` or ``stuck`` before the time limit. The path length is compared
with the world's optimal one, stored in the scene by its check."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

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
from flylog.experiments.runs import score, trajectories, with_flies
from flylog.replay.config import ReplayConfig
from flylog.scene.generate import Family, GenerateConfig

NAME = "navigation"
# worlds per family: the options' seeds N give N passages and N clutter worlds and a
# third as many dead-end ones (`flylog experiment navigation`'s default N = 30: 30, 30, 10)
DEAD_END_SHARE = 3
# the world seeds the experiment reports on; development looks at seeds below 1000 only
HELD_OUT = 1000
TIME_LIMIT = 180.0  # s: as closed-loop's; a run ends earlier at the goal or when it says so


@dataclasses.dataclass(frozen=True)
class _Job:
    here: Path
    options: ExperimentOptions
    family: Family
    seed: int


def plan_navigation(
    out_dir: Path,
    options: ExperimentOptions,
    *,
    counts: dict[Family, int] | None = None,
    first_seed: int = HELD_OUT,
) -> ExperimentPlan:
    """One cell per generated world: ``counts`` worlds of each family (default
    ``options.seeds`` passages and clutter worlds, a third as many dead-end ones, at least
    one), world seeds ``first_seed`` on; the experiment writes ``out_dir/navigation/``."""
    here = experiment_dir(out_dir, NAME)
    n = options.seeds
    counts = counts or {
        Family.PASSAGES: n,
        Family.CLUTTER: n,
        Family.DEAD_END: max(1, math.ceil(n / DEAD_END_SHARE)),
    }
    jobs = [
        _Job(here, options, family, first_seed + k)
        for family, n in counts.items()
        for k in range(n)
    ]
    limit = options.duration_or(TIME_LIMIT)
    cells = tuple(
        ExperimentCell(
            NAME, f"{j.family.value}, world {j.seed}", log_seconds_work(limit, 1), _run, j
        )
        for j in jobs
    )

    def assemble(results: list[dict]) -> ExperimentResult:
        return _finish(here, options, first_seed, results)

    return ExperimentPlan(NAME, cells, assemble)


def _world(job: _Job) -> Path:
    from flylog.io.atomic import write_text
    from flylog.scene.generate import generate_text

    path = job.here / "worlds" / f"{job.family.value}-{job.seed}.toml"
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text(path, generate_text(job.family, job.seed, GenerateConfig()))
    return path


def _run(job: _Job) -> dict:
    """Simulate the closed loop on the job's world and score it (the log is deleted unless
    kept); the run's row."""
    from flylog.experiments.closed_loop import describe_obstacle, touched_obstacles
    from flylog.io import contract
    from flylog.io.reader import open_log
    from flylog.replay.closed_loop import planner_driver
    from flylog.scene.load import load_scene
    from flylog.sim.run import SimulationOptions, simulate

    world = _world(job)
    scene = load_scene(world)
    config = with_flies(ReplayConfig(seed=job.seed), job.options)
    log = job.here / "runs" / f"{job.family.value}-{job.seed}.mcap"
    log.parent.mkdir(parents=True, exist_ok=True)

    limit = job.options.duration_or(TIME_LIMIT)
    sim = SimulationOptions(duration=limit, seed=job.seed, resolution=job.options.resolution)
    simulate(scene, log, sim, make_driver=planner_driver(config))
    ending = open_log(log).metadata()[contract.REPLAY_METADATA].get("ending", "")
    s = score(log, log).summary
    t, true, _ = trajectories(log)
    touched = touched_obstacles(scene, true[:, :2], scene.spec.robot.radius)
    g = scene.spec.generated
    assert g is not None
    optimal = g.optimal_path_m
    reachable = g.reachable
    if reachable:
        success = bool(s["goal_reached"] and s["collisions"] == 0)
    else:
        success = ending in ("unreachable", "stuck")
    row = {
        "family": job.family.value,
        "seed": job.seed,
        "world": str(world.relative_to(job.here)),
        "reachable": reachable,
        "success": success,
        "ending": ending,
        "end_time_s": float(t[-1]),
        "goal_reached": bool(s["goal_reached"]),
        "collisions": int(s["collisions"]),
        "touched": [describe_obstacle(scene, k) for k in touched],
        "time_to_goal_s": s["time_to_goal_s"],
        "path_length_m": s["path_length_m"],
        "optimal_path_m": optimal,
        "path_over_optimal": s["path_length_m"] / optimal if optimal else math.nan,
        "narrowest_gap_m": g.narrowest_gap_m,
        "min_clearance_m": s["min_clearance_m"],
        "final_goal_distance_m": s["final_goal_distance_m"],
        "trajectory": true[:: max(1, len(true) // 400), :2].round(3).tolist(),
    }
    if not job.options.keep_logs:
        log.unlink()
    return row


def failure_mode(row: dict) -> str | None:
    """Why a run failed (None: it succeeded): a collision, the time limit, STUCK, a false
    UNREACHABLE, or a stop off the goal."""
    if row["success"]:
        return None
    if row["collisions"]:
        return "collision"
    if not row["reachable"]:
        return "dead end not recognised before the time limit"
    return {
        "unreachable": "said unreachable on a reachable world",
        "stuck": "ended stuck",
        "duration": "time limit",
    }.get(row["ending"], "stopped off the goal")


def _finish(
    here: Path, options: ExperimentOptions, first_seed: int, runs: list[dict]
) -> ExperimentResult:
    from flylog.experiments.navigation_plots import failure_reports, figures

    table = _table(runs)
    reports = failure_reports(here, runs, failure_mode)
    findings = _findings(runs, table) + [
        f"{mode}: {len(rows)} run(s), e.g. [{rows[0]['family']} world {rows[0]['seed']}]"
        f"(failures/{path.name})"
        for mode, (rows, path) in reports.items()
    ]
    limit = options.duration_or(TIME_LIMIT)
    held = " (held out: never looked at while the planner was developed)"
    setup = [
        f"generated worlds (`flylog scene generate`, the default family parameters), world "
        f"seeds from {first_seed} on" + (held if first_seed >= HELD_OUT else ""),
        f"one closed-loop run per world at {options.resolution[0]}×{options.resolution[1]} "
        "(`flylog simulate --drive planner`), the engine and planner at their defaults"
        + (f", {options.flies} flies" if options.flies else " (5000 flies)")
        + "; the run's seed is the world's",
        f"a run ends at the goal, when the planner says the goal is unreachable, when it has "
        f"said STUCK for planner.stuck_timeout, or after {limit:g} s",
        "success: goal reached (true position within 0.2 m) without collision; on dead-end "
        "worlds: ended unreachable or stuck before the time limit; path / optimal: the true "
        "path's length over the shortest collision-free path of the world's check (a 0.05 m "
        "grid, footprint radius 0.35 m)",
    ]
    return finish_experiment(
        NAME,
        here,
        options,
        title="Navigation on generated worlds",
        intro=__doc__ or "",
        table=table,
        findings=findings,
        figures=figures(here, runs),
        setup=setup,
        runs=runs,
    )


def _table(runs: list[dict]) -> Table:
    rows = []
    for family in Family:
        mine = [r for r in runs if r["family"] == family.value]
        if not mine:
            continue
        reached = [r for r in mine if r["goal_reached"]]
        ratios = [r["path_over_optimal"] for r in reached if math.isfinite(r["path_over_optimal"])]
        rows.append(
            {
                "family": family.value,
                "success": Count(sum(r["success"] for r in mine), len(mine)),
                "collision_free": Count(sum(r["collisions"] == 0 for r in mine), len(mine)),
                "ended": ", ".join(
                    f"{e} {sum(r['ending'] == e for r in mine)}"
                    for e in sorted({r["ending"] for r in mine})
                ),
                "time_to_goal_s": spread([r["time_to_goal_s"] for r in reached]),
                "ratio_median": float(np.median(ratios)) if ratios else math.nan,
                "ratio": spread(ratios),
                "min_clearance_m": spread([r["min_clearance_m"] for r in mine]),
                "end_time_s": spread([r["end_time_s"] for r in mine]),
            }
        )
    columns = (
        Column("family", "family"),
        Column("success", "success"),
        Column("collision_free", "no collision"),
        Column("ended", "ended by"),
        Column("time_to_goal_s", "time to goal (s)", ".1f"),
        Column("ratio_median", "path / optimal, median", ".2f"),
        Column("ratio", "path / optimal", ".2f"),
        Column("min_clearance_m", "min clearance (m)", ".2f"),
        Column("end_time_s", "run's end (s)", ".1f"),
    )
    return Table("Closed loop, one run per generated world", columns, tuple(rows))


def _findings(runs: list[dict], table: Table) -> list[str]:
    out = []
    for row in table.rows:
        mine = [r for r in runs if r["family"] == row["family"]]
        if row["family"] == Family.DEAD_END.value:
            times = ", ".join(f"{r['end_time_s']:.1f} s ({r['ending']})" for r in mine)
            out.append(
                f"`dead-end`: {row['success'].k} of {row['success'].n} worlds ended "
                f"unreachable or stuck before the time limit; ends: {times}"
            )
            continue
        clear = min((r["min_clearance_m"] for r in mine), default=math.nan)
        gaps = [r["narrowest_gap_m"] for r in mine if r["narrowest_gap_m"] is not None]
        out.append(
            f"`{row['family']}`: goal reached without collision on {row['success'].k} of "
            f"{row['success'].n} worlds; path / optimal median {row['ratio_median']:.2f}; "
            f"lowest minimum clearance {clear:.2f} m; narrowest gaps of the worlds "
            f"{min(gaps, default=math.nan):.2f}–{max(gaps, default=math.nan):.2f} m"
        )
    return out
