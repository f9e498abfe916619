"""``flylog replay``: stream a log through the engine and planner on the virtual clock."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pyarrow as pa

from flylog.config import to_mapping
from flylog.errors import LogError
from flylog.io import contract
from flylog.io.pairing import pair_stereo
from flylog.io.reader import open_log
from flylog.io.tables import TableWriter
from flylog.io.writer import LogWriter
from flylog.replay.clock import ClockConfig, VirtualClock
from flylog.replay.config import ReplayConfig
from flylog.replay.inputs import SENSOR_TOPICS, replay_inputs
from flylog.replay.pipeline import PLANNER_TICK, SNAPSHOT_TICK, FlyPipeline

# One row per planner tick (documented in the README).
STEP_SCHEMA = pa.schema(
    [
        ("t", pa.float64()),  # log time, s
        ("generation", pa.int64()),  # generations behind the population the planner saw
        ("evaluations", pa.int64()),  # fitness evaluations so far
        ("valid_flies", pa.int64()),  # flies inside both images with positive fitness
        ("obstacle_flies", pa.int64()),
        ("best_fitness", pa.float64()),
        ("median_fitness", pa.float64()),
        ("image_latency", pa.float64()),  # s: tick time − stamp of the images those flies saw
        ("odom_latency", pa.float64()),  # s: tick time − stamp of the newest odometry
        ("x", pa.float64()),  # odometric pose, m / rad
        ("y", pa.float64()),
        ("theta", pa.float64()),
        ("linear", pa.float64()),  # command, m/s
        ("angular", pa.float64()),  # command, rad/s
        ("status", pa.string()),  # driving | goal_reached | stuck
        ("potential_change", pa.float64()),  # largest change of the tick's last SOR sweep
    ]
)


@dataclass(frozen=True)
class ReplaySummary:
    output: Path
    table: Path
    log_duration: float  # s
    wall_seconds: float
    frames: int
    generations: int
    evaluations: int
    snapshots: int
    status: str  # the planner's last status


def table_path(output: Path) -> Path:
    """The per-step table beside RUN.mcap: RUN.parquet."""
    return output.with_suffix(".parquet")


def clock_config(config: ReplayConfig, frame_period_ns: int) -> ClockConfig:
    return ClockConfig(
        mode=config.mode,
        evals_per_second=config.evals_per_second,
        generations_per_frame=config.generations_per_cycle,
        frame_period_ns=frame_period_ns,
        tick_periods_ns={
            PLANNER_TICK: round(1e9 / config.planner.tick_rate),
            SNAPSHOT_TICK: round(1e9 / config.snapshot_rate),
        },
    )


def replay(
    log: Path,
    output: Path,
    config: ReplayConfig,
    *,
    goal: tuple[float, float] | None = None,
    on_progress: Callable[[float, float], None] | None = None,
) -> ReplaySummary:
    """Replay ``log`` and write ``output`` (MCAP) and its per-step table (Parquet), both
    atomically: after a failure neither exists. ``on_progress(done_s, total_s)`` in log time.
    """
    t0 = time.perf_counter()
    table = table_path(output)
    if table == Path(log) or output == Path(log):
        msg = f"replay would overwrite its input {log}: choose another --output"
        raise LogError(msg)
    reader = open_log(log)
    inputs = replay_inputs(reader, goal=goal)
    duration = (inputs.end_ns - inputs.start_ns) / 1e9
    existed = table.exists()
    try:
        with LogWriter(output) as out, TableWriter(table, STEP_SCHEMA) as rows:
            pipeline = FlyPipeline(
                config, inputs.rig, inputs.start, inputs.goal, out.write, on_row=rows.append
            )
            clock = VirtualClock(pipeline, clock_config(config, inputs.frame_period_ns))
            for message in pair_stereo(reader.messages(SENSOR_TOPICS)):
                clock.feed(message.value)
                if on_progress is not None:
                    on_progress((message.log_time_ns - inputs.start_ns) / 1e9, duration)
            stats = clock.finish(inputs.end_ns)
            wall = time.perf_counter() - t0
            out.add_metadata(
                contract.REPLAY_METADATA,
                {
                    "config": json.dumps(to_mapping(config)),
                    "log": str(log),
                    "goal": json.dumps(list(inputs.goal)),
                    "generations": str(stats.generations),
                    "evaluations": str(stats.evaluations),
                    "frames": str(stats.frames),
                    "wall_seconds": f"{wall:.3f}",
                    "log_duration": f"{duration:.3f}",
                },
            )
    except BaseException:
        if not existed:
            table.unlink(missing_ok=True)
        raise
    return ReplaySummary(
        output=output,
        table=table,
        log_duration=duration,
        wall_seconds=time.perf_counter() - t0,
        frames=stats.frames,
        generations=stats.generations,
        evaluations=stats.evaluations,
        snapshots=pipeline.snapshots,
        status=pipeline.command.status.value,
    )
