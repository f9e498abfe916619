"""``flylog replay``: stream a log through the engine and planner on the virtual clock."""

from __future__ import annotations

import dataclasses
import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from flylog.budget import DEFAULT_LIMITS, Limits
from flylog.config import to_mapping
from flylog.geometry import StereoRig
from flylog.io import contract
from flylog.io.atomic import Batch
from flylog.io.collisions import Role, check_outputs
from flylog.io.fingerprint import log_fingerprint
from flylog.io.tables import TableWriter
from flylog.io.writer import Compression, LogWriter
from flylog.replay.clock import ClockConfig, VirtualClock
from flylog.replay.config import ReplayConfig, Stereo
from flylog.replay.engines import photometric_evaluations
from flylog.replay.estimate import check_sampling_rates, replay_estimate
from flylog.replay.exposure import ExposureWatch
from flylog.replay.pipeline import PLANNER_TICK, SNAPSHOT_TICK, FlyPipeline
from flylog.replay.planner_jobs import STEP_COLUMNS
from flylog.ros2.config import BagOptions
from flylog.sensors import StereoPair
from flylog.sources import input_at
from flylog.sources.stream import PLANNER_OFF, READ_AHEAD_MESSAGES

# The run log is written with zstd chunks: its bulk is float32 potentials and fly clouds,
# which zstd shrinks to 0.71 (lz4: 0.90) of their size; on the corridor's 6 s at 640×480
# (docs/performance.md) writing costs 0.087 s of CPU against 0.022 s uncompressed, 0.3 % of
# the replay's wall time, and reading it back (flylog metrics) 0.014 s against 0.004 s.
RUN_COMPRESSION = Compression.ZSTD
# Progress is reported at most this often, in log time (the log has ~90 messages a second).
PROGRESS_STEP_NS = 100_000_000

__all__ = ["READ_AHEAD_MESSAGES", "ReplaySummary", "clock_config", "replay", "table_path"]


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
    status: str  # the planner's last status ("off": no planner)
    stereo: str  # the engine: flies or sgbm
    unpaired: int = 0  # images dropped for want of a partner (ROS 2 bags)
    row_period_ns: float = 0.0  # the cameras' row period replayed with (0: a global shutter)


def table_path(output: Path) -> Path:
    """The per-step table beside RUN.mcap: RUN.parquet."""
    return output.with_suffix(".parquet")


def clock_config(config: ReplayConfig, rig: StereoRig, *, planner: bool = True) -> ClockConfig:
    ticks = {
        PLANNER_TICK: round(1e9 / config.planner.tick_rate),
        SNAPSHOT_TICK: round(1e9 / config.snapshot_rate),
    }
    if not planner:
        del ticks[PLANNER_TICK]
    return ClockConfig(
        mode=config.mode,
        generations_per_frame=config.generations_per_cycle,
        frame_period_ns=round(1e9 / rig.frame_rate),
        tick_periods_ns=ticks,
        # SGBM's cost is fixed; the first generation after a stereo pair also pays for the
        # heading's measurement
        max_generation_cost_ns=config.generation_cost_ns(
            config.engine.max_evaluations
            + config.obstacles.most_distinct_evaluations(config.engine.flies)
            + config.heading.max_evaluations
            + photometric_evaluations(config, rig)
        ),
        # no stale fly and no distinctness charged (that comes with the first after a tick)
        max_later_generation_cost_ns=config.generation_cost_ns(config.engine.max_later_evaluations),
    )


def _without_robot(config: ReplayConfig, *, ground: bool, planner: bool) -> ReplayConfig:
    """The configuration the pipeline runs: without a ground plane the obstacle rule keeps
    flies at any height; without a planner the potential needs no warm start."""
    if not ground:
        rule = dataclasses.replace(config.obstacles, ground_margin=-math.inf)
        config = dataclasses.replace(config, obstacles=rule)
    if not planner:
        grid = dataclasses.replace(config.planner, warm_start_sweeps=0)
        config = dataclasses.replace(config, planner=grid)
    return config


def replay(
    log: Path,
    output: Path,
    config: ReplayConfig,
    *,
    goal: tuple[float, float] | None = None,
    bag: BagOptions | None = None,
    row_period_us: float | None = None,
    on_progress: Callable[[float, float], None] | None = None,
    limits: Limits = DEFAULT_LIMITS,
) -> ReplaySummary:
    """Replay ``log`` (a flylog log or a ROS 2 bag, read with ``bag``'s options) and write
    ``output`` (MCAP) and its per-step table (Parquet), both atomically: after a failure
    neither exists. ``row_period_us``: the cameras' row period, for any input, instead of a
    log's flylog.shutter record (a global shutter without one); the run's metadata records
    the one in effect. ``on_progress(done_s, total_s)`` in log time. Without a goal (a bag
    without one, and no ``goal``), the planner's outputs are not written. A job whose
    estimated output or memory is over ``limits`` is refused before it starts."""
    t0 = time.perf_counter()
    table = table_path(output)
    check_outputs(
        [Role(Path(log), "the sensor log", "log")],
        [Role(Path(output), "the run", "output"), Role(table, "the step table", "output")],
    )
    source = input_at(log).replay_source(goal=goal, bag=bag, row_period_us=row_period_us)
    inputs = source.inputs
    fingerprint = log_fingerprint(log)
    duration = (inputs.end_ns - inputs.start_ns) / 1e9
    check_sampling_rates(config, inputs.rig.frame_rate, source=f"the log {log}")
    replay_estimate(config, inputs.rig, duration).check(limits)
    engine_config = _without_robot(config, ground=inputs.has_ground, planner=inputs.has_planner)
    # the run and its step table are published together: both new, or both as they were
    with (
        Batch() as batch,
        LogWriter(output, compression=RUN_COMPRESSION, batch=batch) as out,
        TableWriter(table, STEP_COLUMNS, batch=batch) as rows,
    ):
        pipeline = FlyPipeline(
            engine_config,
            inputs.rig,
            inputs.start,
            inputs.goal,
            out.write,
            on_row=rows.append,
            planner_thread=True,
            planner=source.planner,
            row_period_ns=inputs.row_period_ns,
        )
        try:
            clock = VirtualClock(
                pipeline,
                clock_config(config, inputs.rig, planner=inputs.has_planner),
            )
            reported_ns = inputs.start_ns
            watch = ExposureWatch(config.engine, f"the log {log}")
            watch.done |= config.stereo is not Stereo.FLIES
            for message in source.records:
                if isinstance(message.value, StereoPair):
                    watch.look(message.value.left, message.value.right)
                clock.feed(message.value)
                if on_progress is not None and message.log_time_ns >= reported_ns:
                    on_progress((message.log_time_ns - inputs.start_ns) / 1e9, duration)
                    reported_ns = message.log_time_ns + PROGRESS_STEP_NS
            stats = clock.finish(inputs.end_ns)
            watch.finish()
            if inputs.frames == 1:
                # the population after all the generations made on the one pair
                pipeline.tick(SNAPSHOT_TICK, max(stats.now_ns, inputs.end_ns + 1))
            if on_progress is not None:
                on_progress(duration, duration)
            pipeline.flush()
        finally:
            pipeline.close()
        wall = time.perf_counter() - t0
        out.add_metadata(
            contract.REPLAY_METADATA,
            {
                "config": json.dumps(to_mapping(config)),
                "log": str(log),
                "log_fingerprint": fingerprint,
                "goal": json.dumps(list(inputs.goal) if source.planner else None),
                "generations": str(stats.generations),
                "evaluations": str(stats.evaluations),
                "frames": str(stats.frames),
                "wall_seconds": f"{wall:.3f}",
                "log_duration": f"{duration:.3f}",
                "ground_test": json.dumps(inputs.has_ground),
                "planner": json.dumps(inputs.has_planner),
                "row_period_ns": json.dumps(inputs.row_period_ns),
            },
        )
    return ReplaySummary(
        output=output,
        table=table,
        log_duration=duration,
        wall_seconds=time.perf_counter() - t0,
        frames=stats.frames,
        generations=stats.generations,
        evaluations=stats.evaluations,
        snapshots=pipeline.snapshots,
        status=pipeline.command.status.value if source.planner else PLANNER_OFF,
        stereo=config.stereo.value,
        unpaired=source.unpaired,
        row_period_ns=inputs.row_period_ns,
    )
