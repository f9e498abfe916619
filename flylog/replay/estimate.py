"""A replay's (or closed loop's) bounds, checked before it starts: its output and peak
memory estimated from its configuration (:class:`flylog.budget.Estimate`), and the rates it
samples the stereo stream at against the camera's."""

from __future__ import annotations

from flylog.budget import Estimate
from flylog.errors import ConfigError
from flylog.geometry import StereoRig
from flylog.replay.config import ReplayConfig

# A rate sampling the stereo stream (snapshots, planner ticks) at most this many times per
# stereo pair: more samples see no new data, only cost output and time.
MAX_SAMPLES_PER_FRAME = 10

# A replay snapshot: the potential as float32 (4 B a cell), each fly as 24 B (the /flies
# point cloud), each overlay fly as 48 B of annotation, the path as up to 100 B per cell of
# the grid's side; measured on turn.mcap: 160 100 B for 200 x 200 cells, 120 124 B for
# 5000 flies, 48 754 B for 1000 overlay flies, 19 551 B of path.
POTENTIAL_BYTES_PER_CELL = 4
FLY_BYTES = 24
OVERLAY_FLY_BYTES = 48
PATH_BYTES_PER_SIDE_CELL = 100
# Replay memory (peak RSS on turn.mcap): 453 MiB at the defaults with numba compiling its
# kernels, 260 MiB with them cached; 879 MiB with planner.extent = 200 m (2000 x 2000 cells
# instead of 200 x 200: the planner's masks, counters, obstacle values, the relaxation's
# halves, the snapshots' copies), i.e. 160 B a cell; 535 MiB with 400 000 flies instead of
# 5000, i.e. 730 B a fly (population, scores, operators' work arrays). About twelve stereo
# pairs are read ahead (READ_AHEAD_MESSAGES of flylog.replay.run, 3 B/px).
PLANNER_BYTES_PER_CELL = 160
FLY_MEMORY_BYTES = 750
READ_AHEAD_PAIRS = 12
REPLAY_PROGRAM_BYTES = 453 * 2**20


def replay_output_bytes(config: ReplayConfig, duration: float) -> float:
    """What a replay (or closed loop) of ``duration`` seconds of log writes: its snapshots."""
    side = config.planner.cells
    snapshots = duration * config.snapshot_rate + 1
    per_snapshot = (
        POTENTIAL_BYTES_PER_CELL * side * side
        + FLY_BYTES * config.engine.flies
        + OVERLAY_FLY_BYTES * config.overlay_flies
        + PATH_BYTES_PER_SIDE_CELL * side
    )
    return snapshots * per_snapshot


def replay_estimate(config: ReplayConfig, rig: StereoRig, duration: float) -> Estimate:
    """A replay (or closed loop) of ``duration`` seconds of log: its snapshots, the planner's
    grids and the stereo pairs read ahead."""
    side = config.planner.cells
    memory = (
        REPLAY_PROGRAM_BYTES
        + PLANNER_BYTES_PER_CELL * side * side
        + FLY_MEMORY_BYTES * config.engine.flies
        + READ_AHEAD_PAIRS * 2 * rig.width * rig.height * 3
    )
    return Estimate(f"a replay of {duration:g} s", replay_output_bytes(config, duration), memory)


def check_sampling_rates(config: ReplayConfig, frame_rate: float, *, source: str) -> None:
    """Refuse a snapshot or planner tick rate above MAX_SAMPLES_PER_FRAME × the camera's
    frame rate (``source``: what the frame rate comes from, for the message)."""
    most = MAX_SAMPLES_PER_FRAME * frame_rate
    problems = [
        f"{name} = {rate:g} Hz is above {most:g} Hz, {MAX_SAMPLES_PER_FRAME} times the "
        f"camera's frame rate in {source} ({frame_rate:g} Hz)"
        for name, rate in (
            ("snapshot_rate", config.snapshot_rate),
            ("planner.tick_rate", config.planner.tick_rate),
        )
        if rate > most
    ]
    if problems:
        parameter = "snapshot_rate" if config.snapshot_rate > most else "tick_rate"
        raise ConfigError("; ".join(problems), parameter=parameter)
