"""Bounds checked before a job starts: its output size and peak memory against limits, and
the rates a replay samples at against the camera's.

The estimates are upper bounds built from what the job writes and keeps (see each constant's
measurement); a job over a limit is refused with the estimate, before any work is done.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from flylog.errors import ConfigError, LimitError

if TYPE_CHECKING:
    from flylog.geometry import StereoRig
    from flylog.replay.config import ReplayConfig

GIB = 2**30

# A rate sampling the stereo stream (snapshots, planner ticks) at most this many times per
# stereo pair: more samples see no new data, only cost output and time.
MAX_SAMPLES_PER_FRAME = 10

# What the program itself holds before a job's own data (modules, numba's compiled kernels):
# peak RSS of `flylog simulate` at 160x120 with numba compiling its kernels, 285 MB.
PROGRAM_BYTES = 300 * 2**20
# Simulation memory per pixel of one image (render buffers, depth, both images): peak RSS
# 228 MB at 640x480, 246 MB at 1280x960, 280 MB at 1920x1440, i.e. 20-21 B/px.
SIMULATION_BYTES_PER_PIXEL = 24
# Per scheduled sensor event (a (time, order, kind) tuple and its heap slot) and per
# odometry step (two poses kept for the trajectory record): CPython object sizes.
EVENT_BYTES = 130
POSE_STEP_BYTES = 200
# A log's messages besides the images (odometry, sonar, transforms, calibrations, the
# scene) and its fixed part (the scene attachment, metadata, summary): uncompressed logs of
# turn.toml held 112 kB besides the images in 2 s at 640x480, 46 kB in 0.5 s at 64x48.
OTHER_LOG_BYTES_PER_S = 64_000
LOG_FIXED_BYTES = 32 * 1024
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


@dataclass(frozen=True)
class Limits:
    """The largest job accepted: estimated output and peak memory, in bytes."""

    max_output_size: int = 32 * GIB
    max_memory: int = 8 * GIB


DEFAULT_LIMITS = Limits()

# A sweep's default bounds (flylog.sweep.limits), checked from its spec: a 10 000-cell sweep
# of ~2 s cells (the fixture logs' at the tiny test settings) runs for hours on a
# workstation, and planning a million cells alone takes over a minute; its estimated output
# is bounded as simulate's and replay's are.
SWEEP_MAX_CELLS = 10_000
SWEEP_MAX_OUTPUT_SIZE = DEFAULT_LIMITS.max_output_size


@dataclass(frozen=True)
class Estimate:
    """What a job is expected to write and to hold at its peak, bytes."""

    job: str
    output_bytes: float
    memory_bytes: float

    def check(self, limits: Limits) -> None:
        """Raise LimitError if the estimate is over a limit (``parameter``: that limit)."""
        if self.output_bytes > limits.max_output_size:
            msg = (
                f"{self.job} would write about {size_text(self.output_bytes)}, over the limit of "
                f"{size_text(limits.max_output_size)} on outputs"
            )
            raise LimitError(msg, parameter="max_output_size")
        if self.memory_bytes > limits.max_memory:
            msg = (
                f"{self.job} would need about {size_text(self.memory_bytes)} of memory, over the "
                f"limit of {size_text(limits.max_memory)}"
            )
            raise LimitError(msg, parameter="max_memory")


def size_text(n: float) -> str:
    for unit, scale in (("TiB", 2**40), ("GiB", GIB), ("MiB", 2**20)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n / 1024:.3g} KiB"


def simulation_estimate(
    rig: StereoRig, duration: float, *, sonar_rate: float, odometry_rate: float
) -> Estimate:
    """A simulation of ``duration`` seconds: images uncompressed (lz4 wrote 48 % of it on
    turn.toml at 640x480), every event scheduled at the start."""
    frames = duration * rig.frame_rate + 1
    pixels = rig.width * rig.height
    output = frames * 2 * pixels * 3 + duration * OTHER_LOG_BYTES_PER_S + LOG_FIXED_BYTES
    events = duration * (rig.frame_rate + sonar_rate + odometry_rate + 1)
    memory = (
        PROGRAM_BYTES
        + SIMULATION_BYTES_PER_PIXEL * pixels
        + EVENT_BYTES * events
        + POSE_STEP_BYTES * duration * odometry_rate
    )
    return Estimate(f"a {duration:g} s simulation", output, memory)


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
