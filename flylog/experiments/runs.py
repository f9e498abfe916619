"""One seed of an experiment: simulate a scene, replay the log, score the run; and what the
plots read back from the logs (images, fly snapshots, trajectories)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from flylog.config import replace_dotted
from flylog.experiments.cell_progress import stage
from flylog.experiments.common import ExperimentOptions
from flylog.replay.config import ReplayConfig


@dataclass(frozen=True)
class ScoredRun:
    """A scored run: its files and the three metric tables."""

    log: Path
    run: Path
    summary: dict[str, Any]
    snapshots: list[dict[str, Any]]
    obstacles: list[dict[str, Any]]


def simulate_scene(
    options: ExperimentOptions,
    scene_name: str,
    seed: int,
    output: Path,
    duration: float,
    *,
    drive_with: ReplayConfig | None = None,
) -> Path:
    """Simulate ``scene_name`` at the options' resolution; ``drive_with``: closed loop, the
    engine and planner with that configuration drive the robot."""
    from flylog.replay.closed_loop import planner_driver
    from flylog.scene.load import load_scene
    from flylog.sim.run import SimulationOptions, simulate

    scene = load_scene(options.scene_path(scene_name))
    make_driver = None if drive_with is None else planner_driver(drive_with)
    sim = SimulationOptions(duration=duration, seed=seed, resolution=options.resolution)
    simulate(scene, output, sim, make_driver=make_driver, on_frame=stage(duration))
    return output


def one_generation_per_frame(
    seed: int, frame_rate: float, switches: dict[str, bool]
) -> ReplayConfig:
    """The paper's set-up: one generation per frame, a snapshot per frame, the engine's
    ``switches`` (e.g. ``{"proprioception": False}``) applied to the defaults."""
    overrides: dict[str, object] = {
        "seed": seed,
        "generations_per_frame": 1,
        "snapshot_rate": frame_rate,
    }
    overrides.update({f"engine.{name}": on for name, on in switches.items()})
    return replace_dotted(ReplayConfig(), overrides)


def with_flies(config: ReplayConfig, options: ExperimentOptions) -> ReplayConfig:
    return replace_dotted(config, {"engine.flies": options.flies})


def replay_and_score(log: Path, run: Path, config: ReplayConfig) -> ScoredRun:
    """Replay ``log`` with ``config`` into ``run`` and score it against the log's truth."""
    from flylog.replay.run import replay

    replay(log, run, config, on_progress=stage())
    return score(run, log)


# The experiments' images are small: their truth is rendered at every pixel (flylog metrics
# renders 640×480 in 4×4 blocks for speed; a threshold metric such as the detection latency
# can move with a single fly judged against an interpolated depth).
EVERY_PIXEL = 1_000_000  # MetricsConfig.truth_width at or above the image width


def score(run: Path, log: Path) -> ScoredRun:
    from flylog.metrics.config import MetricsConfig
    from flylog.metrics.score import score_run

    result = score_run(run, log, MetricsConfig(truth_width=EVERY_PIXEL))
    return ScoredRun(log, run, result.summary, result.snapshots, result.obstacles)


# ---- reading back what the plots show ------------------------------------------------------


def fly_snapshots(run: Path) -> tuple[np.ndarray, list[np.ndarray]]:
    """Times (ns) and the obstacle flies (M, 3) in base_link of every ``/flies`` snapshot,
    by the run's own obstacle rule (its metadata)."""
    from flylog.io import contract, open_log
    from flylog.metrics.config import MetricsConfig
    from flylog.metrics.result import run_facts

    reader = open_log(run)
    rule = run_facts(reader, MetricsConfig()).rule
    times, clouds = [], []
    for m in reader.messages([contract.FLIES]):
        cloud = m.value
        keep = rule.mask(cloud.xyz, cloud.fitness, cloud.age, cloud.distinct)
        times.append(m.log_time_ns)
        clouds.append(np.array(cloud.xyz[keep], dtype=float))
    return np.array(times, dtype=np.int64), clouds


def left_image_at(log: Path, t_ns: int) -> tuple[int, np.ndarray]:
    """The first left image stamped at or after ``t_ns`` (else the last): stamp, RGB copy."""
    from flylog.io import contract, open_log

    found: tuple[int, np.ndarray] | None = None
    for m in open_log(log).messages([contract.LEFT_IMAGE]):
        found = (m.log_time_ns, np.array(m.value))
        if m.log_time_ns >= t_ns:
            break
    if found is None:
        msg = f"{log} has no left images"
        raise ValueError(msg)
    return found


def trajectories(log: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times (s since the first true pose), true (N, 3) and odometric (N, 3) poses of a
    sensor log, the odometry interpolated at the true poses' times."""
    from flylog.metrics.trajectory import interpolate_poses
    from flylog.sources import read_truth

    truth = read_truth(log)
    t = truth.true.t_ns
    return (t - t[0]) / 1e9, truth.true.xyt, interpolate_poses(truth.odom, t)


def true_poses_at(log: Path, t_ns: np.ndarray) -> np.ndarray:
    """(M, 3) true poses interpolated at the given log times."""
    from flylog.metrics.trajectory import interpolate_poses
    from flylog.sources import read_truth

    return interpolate_poses(read_truth(log).true, np.asarray(t_ns, dtype=np.int64))


def to_world(xyz: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """(M, 2) world x, y of base_link points seen from ``pose`` (x, y, theta)."""
    from flylog.geometry import Pose2D, transform_points_2d

    return transform_points_2d(Pose2D(*(float(v) for v in pose)), np.asarray(xyz)[:, :2])
