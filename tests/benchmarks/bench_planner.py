"""Harmonic planner: sweep throughput (numba vs numpy reference) and re-convergence ticks."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from flylog.geometry import Pose2D
from flylog.planner import HarmonicPlanner, PathEnd, PlannerConfig, sor_sweeps_numba
from flylog.planner.relax import sor_sweeps_numpy

CHANGE_TOL = 1e-6  # largest change of a sweep below which the field counts as re-converged
MAX_TICKS = 1000


def _sweeps_per_second(sweep, u: np.ndarray, fixed: np.ndarray, omega: float) -> float:
    sweep(u, fixed, omega, 1)  # compile / warm caches
    n, elapsed = 0, 0.0
    batch = 5
    while elapsed < 1.0:
        t0 = time.perf_counter()
        sweep(u, fixed, omega, batch)
        elapsed += time.perf_counter() - t0
        n += batch
        batch *= 2
    return n / elapsed


def _directed_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Largest distance from a point of ``a`` to the nearest point of ``b``."""
    d = np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1])
    return float(d.min(axis=1).max())


def _reconvergence(cfg: PlannerConfig) -> dict[str, float]:
    robot = Pose2D(0.0, 0.0, 0.0)
    planner = HarmonicPlanner.centred_on(cfg, (0.0, 0.0), (8.0, 0.0))
    warm = planner.relax_until(  # as the replay's warm start does
        cfg.relax_tolerance, 200_000, chunk=100, omega=cfg.warm_start_omega
    )
    at_omega = HarmonicPlanner.centred_on(cfg, (0.0, 0.0), (8.0, 0.0))
    warm_at_omega = at_omega.relax_until(cfg.relax_tolerance, 200_000, chunk=100)
    ys = np.arange(-1.0, 1.0, 0.02)
    wall = np.column_stack([np.full_like(ys, 1.5), ys])
    for _ in range(cfg.confirm_after_views):  # a cell becomes an obstacle once confirmed
        planner.update_obstacles(wall, robot, np.radians(30.0))
    assert planner.detected_mask.any(), "the wall was not taken for an obstacle"
    previous = planner.trace_path(robot)
    ticks_change = ticks_path = -1
    tick_seconds = []
    for tick in range(1, MAX_TICKS + 1):
        t0 = time.perf_counter()
        change = planner.relax()
        planner.command(robot, tick * cfg.tick_period)
        path = planner.trace_path(robot)
        tick_seconds.append(time.perf_counter() - t0)
        stable = (
            path.end is PathEnd.GOAL
            and previous.end is PathEnd.GOAL
            and max(
                _directed_distance(path.points, previous.points),
                _directed_distance(previous.points, path.points),
            )
            < cfg.cell_size
        )
        if stable and ticks_path < 0:
            ticks_path = tick
        if change < CHANGE_TOL and ticks_change < 0:
            ticks_change = tick
        previous = path
        if ticks_change > 0 and ticks_path > 0:
            break
    return {
        "warm_sweeps": warm.sweeps,
        "warm_sweeps_at_omega": warm_at_omega.sweeps,
        "ticks_change": ticks_change,
        "ticks_path": ticks_path,
        "tick_ms": 1e3 * float(np.median(tick_seconds)),
    }


def run(out_dir: Path) -> list[dict]:
    cfg = PlannerConfig()
    n = cfg.cells
    rng = np.random.default_rng(0)
    fixed = np.zeros((n, n), dtype=bool)
    fixed[[0, -1], :] = True
    fixed[:, [0, -1]] = True
    fixed |= rng.random((n, n)) < 0.05
    u0 = rng.random((n, n))
    fast = _sweeps_per_second(sor_sweeps_numba, u0.copy(), fixed, cfg.omega)
    slow = _sweeps_per_second(sor_sweeps_numpy, u0.copy(), fixed, cfg.omega)
    rc = _reconvergence(cfg)
    note = f"default config: {n}x{n} cells, {cfg.sweeps_per_tick} sweeps/tick, omega {cfg.omega}"
    return [
        {
            "name": f"sor_sweeps_per_s_numba_{n}x{n}",
            "value": fast,
            "unit": "sweeps/s",
            "reference": "numpy reference",
            "ratio": fast / slow,
        },
        {"name": f"sor_sweeps_per_s_numpy_{n}x{n}", "value": slow, "unit": "sweeps/s"},
        {
            "name": "ticks_to_reconverge_max_change",
            "value": rc["ticks_change"],
            "unit": "ticks",
            "note": f"{note}; wall 1.5 m ahead; largest sweep change < {CHANGE_TOL:g} "
            f"(-1 = not within {MAX_TICKS} ticks)",
        },
        {
            "name": "ticks_to_stable_path",
            "value": rc["ticks_path"],
            "unit": "ticks",
            "note": "path reaches the goal and moves < 1 cell between ticks",
        },
        {
            "name": "initial_convergence_sweeps",
            "value": rc["warm_sweeps"],
            "unit": "sweeps",
            "ratio": rc["warm_sweeps"] / rc["warm_sweeps_at_omega"],
            "reference": f"the same at planner.omega ({rc['warm_sweeps_at_omega']} sweeps)",
            "note": "the warm start: from the log-distance initial guess to largest change "
            f"< 1e-10 at planner.warm_start_omega {cfg.warm_start_omega:.4f}",
        },
        {
            "name": "tick_time_median",
            "value": rc["tick_ms"],
            "unit": "ms",
            "note": "relax + command + path trace",
        },
    ]
