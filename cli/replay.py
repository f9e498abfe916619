"""``flylog replay``: thin wrapper over :func:`flylog.replay.run.replay`."""

from __future__ import annotations

from pathlib import Path

import click

from flylog.cli.common import (
    Finite,
    OutputPath,
    limit_options,
    point,
    progress_bar,
    reports_errors,
    stdout,
)
from flylog.cli.config_options import config_option, config_overrides
from flylog.cli.main import freeze_imported_objects

REPLAY = "flylog.replay.config:ReplayConfig"


@click.command()
@click.argument("log", type=click.Path(path_type=Path))
@click.option(
    "-o",
    "--output",
    type=OutputPath(dir_okay=False, path_type=Path),
    required=True,
    help="RUN.mcap to write; the per-step table goes beside it as RUN.parquet. Both are "
    "written atomically: after a failure or Ctrl-C neither exists.",
)
@click.option(
    "--config",
    "config_file",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="TOML file with the whole configuration (top-level options, [engine], [sgbm], "
    "[planner], [obstacles], [heading]); the options below override it. [default: built-in "
    "defaults]",
)
@config_option(REPLAY, "stereo", "--engine", "stereo")
@config_option(REPLAY, "seed", "--seed", metavar="N")
@config_option(REPLAY, "engine.flies", "--flies", metavar="N")
@config_option(REPLAY, "generations_per_frame", "--generations-per-frame", metavar="N")
@config_option(REPLAY, "evals_per_second", "--evals-per-second", metavar="X")
@config_option(REPLAY, "sync", "--sync", flag=True)
@config_option(REPLAY, "snapshot_rate", "--snapshot-rate", metavar="HZ")
@click.option(
    "--goal",
    callback=point,
    default=None,
    metavar="X,Y",
    help="Goal in the odom frame, m. [default: the log's mission metadata; a ROS 2 bag's "
    "custom_data flylog.goal, else none: the planner off]",
)
@click.option(
    "--row-period",
    "row_period_us",
    type=Finite(min=0.0),
    default=None,
    metavar="US",
    help="The cameras' rolling shutter, for any input (a log, an imported dataset, a ROS 2 "
    "bag): the time from one image row's exposure to the next's, in microseconds; row v is "
    "exposed at the image's stamp + v x US (0: a global shutter). A rolling-shutter CMOS "
    "reads a row in about 19 us (18.9 us on Sony's IMX219). The readout, image height x US, "
    "must fit in a frame period. [default: the log's flylog.shutter record, 0 (global "
    "shutter) without one]",
)
@click.option(
    "--topic",
    "topics",
    multiple=True,
    metavar="ROLE=TOPIC",
    help="ROS 2 bags: the topic of a role, overriding the discovery (left, right: image "
    "topics with a camera_info beside them; odom: an Odometry topic or /tf; sonar=/r0,/r1: "
    "the Range topics of the ring); repeatable. [default: found by type and name]",
)
@click.option(
    "--pair-tolerance",
    type=click.FloatRange(0.0, 1.0),
    default=None,
    metavar="PERIODS",
    help="ROS 2 bags: left and right images pair by nearest stamp when at most this many "
    "frame periods apart; unpaired images are dropped and counted. [default: 0.5]",
)
@click.option(
    "--sonar-window",
    type=click.FloatRange(min=0.0),
    default=None,
    metavar="S",
    help="ROS 2 bags: Range readings within this time of a cycle's first form one sonar "
    "cycle. [default: 0.05 s]",
)
@limit_options
@reports_errors
def replay(
    log: Path,
    output: Path,
    config_file: Path | None,
    stereo: str | None,
    seed: int | None,
    flies: int | None,
    generations_per_frame: int | None,
    evals_per_second: float | None,
    sync: bool | None,
    snapshot_rate: float | None,
    goal: tuple[float, float] | None,
    row_period_us: float | None,
    topics: tuple[str, ...],
    pair_tolerance: float | None,
    sonar_window: float | None,
    max_output_size: int,
    max_memory: int,
) -> None:
    """Replay LOG (an MCAP log from `flylog simulate`, or a ROS 2 bag: a ros2-profile .mcap
    file or a rosbag2 directory) through the fly engine (or the SGBM baseline) and the
    harmonic-function planner on a deterministic virtual clock. Never reads /truth/. A bag
    without a goal and no --goal replays the engine only, the planner off.

    A job whose estimated output or peak memory is over --max-output-size or --max-memory
    is refused before it starts, with the estimate."""
    from flylog.budget import Limits
    from flylog.config import replace_dotted
    from flylog.io.collisions import Role, check_outputs
    from flylog.replay.config import ReplayConfig, Stereo, load_replay_config
    from flylog.replay.run import replay as run_replay
    from flylog.replay.run import table_path
    from flylog.ros2.config import BagOptions

    freeze_imported_objects()
    check_outputs(
        [Role(log, "the sensor log", "log")]
        + ([Role(config_file, "the configuration", "config_file")] if config_file else []),
        [Role(output, "the run", "output"), Role(table_path(output), "the step table", "output")],
    )

    config = load_replay_config(config_file) if config_file else ReplayConfig()
    overrides = config_overrides()
    # last: the cross-field check (sgbm runs one step per frame) sees the final options
    overrides["stereo"] = overrides.pop("stereo")
    # a ConfigError (a range or a cross-field check, e.g. sgbm with several generations) is
    # one line and exit 2, the option named where the check knows it
    config = replace_dotted(config, overrides)
    bag = replace_dotted(
        BagOptions(),
        {"topics": topics or None, "pair_tolerance": pair_tolerance, "sonar_window": sonar_window},
    )
    with progress_bar(f"replay {log.name}", unit="s", kernels=True) as update:
        summary = run_replay(
            log,
            output,
            config,
            goal=goal,
            bag=bag,
            row_period_us=row_period_us,
            on_progress=update,
            limits=Limits(max_output_size=max_output_size, max_memory=max_memory),
        )
    speed = summary.log_duration / summary.wall_seconds
    if summary.stereo == Stereo.SGBM.value:
        work = f"{summary.generations} frames matched by SGBM"
    else:
        work = f"{summary.generations} generations, {summary.evaluations / 1e6:.2f} M evaluations"
    stdout.print(
        f"{summary.output} and {summary.table.name}: {summary.log_duration:g} s of log "
        f"replayed in {summary.wall_seconds:.1f} s ({speed:.1f}× real time), "
        f"{summary.frames} frames, {work}, {summary.snapshots} snapshots, "
        f"planner {summary.status}"
        + (
            f", rolling shutter of {summary.row_period_ns / 1000.0:g} us a row"
            if summary.row_period_ns
            else ""
        )
        + (f", {summary.unpaired} unpaired images dropped" if summary.unpaired else ""),
        soft_wrap=True,
    )
