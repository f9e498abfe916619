"""``flylog simulate``: thin wrapper over :func:`flylog.sim.run.simulate`."""

from __future__ import annotations

from pathlib import Path

import click

from flylog.cli.common import human_bytes, progress_bar, reports_errors, resolution, stdout


@click.command()
@click.argument("scene", type=click.Path(dir_okay=False, path_type=Path))
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, path_type=Path),
    required=True,
    help="Where to write the MCAP log (written atomically: nothing appears there on failure).",
)
@click.option(
    "--duration",
    type=click.FloatRange(min=0.0, min_open=True),
    default=None,
    metavar="SECONDS",
    help="Simulated time in seconds. [default: the scene's `duration`, else 20 s]",
)
@click.option(
    "--seed",
    type=click.IntRange(min=0),
    default=0,
    show_default=True,
    metavar="N",
    help="Seed of the trajectory and sonar noise; same scene and seed, same log.",
)
@click.option(
    "--resolution",
    callback=resolution,
    default=None,
    metavar="WxH",
    help="Image size in pixels, e.g. 320x240; the focal length scales with the width so the "
    "field of view stays the scene's. [default: the scene's camera, 640x480]",
)
@click.option(
    "--frame-rate",
    type=click.FloatRange(min=0.1),
    default=None,
    metavar="HZ",
    help="Stereo pairs per second. [default: the scene's camera.frame_rate, 15 Hz]",
)
@click.option(
    "--compression",
    type=click.Choice(["zstd", "lz4", "none"]),
    default="lz4",
    show_default=True,
    help="MCAP chunk compression (lz4: fastest to write; zstd: about 40% smaller, twice the CPU).",
)
@click.option(
    "--drive",
    type=click.Choice(["plan", "planner"]),
    default="plan",
    show_default=True,
    help="plan: the scene's [drive] plan; planner: closed loop, the fly engine and the "
    "harmonic planner drive the robot (paper Fig. 6) and their outputs go into the log too; "
    "the simulation ends when the goal is reached.",
)
@click.option(
    "--config",
    "config_file",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="With --drive planner: the engine/planner configuration, as for `flylog replay "
    "--config`. [default: built-in defaults]",
)
@reports_errors
def simulate(
    scene: Path,
    output: Path,
    duration: float | None,
    seed: int,
    resolution: tuple[int, int] | None,
    frame_rate: float | None,
    compression: str,
    drive: str,
    config_file: Path | None,
) -> None:
    """Simulate the robot in SCENE (a TOML scene file) and record stereo frames, sonar,
    odometry and ground truth as an MCAP log."""
    from flylog.io.writer import Compression, LogConfig
    from flylog.scene.load import load_scene
    from flylog.sim.run import SimulationOptions
    from flylog.sim.run import simulate as run_simulation

    loaded = load_scene(scene)
    options = SimulationOptions(
        duration=duration,
        seed=seed,
        resolution=resolution,
        frame_rate=frame_rate,
        log=LogConfig(compression=Compression(compression)),
    )
    make_driver = None
    if drive == "planner":
        from flylog.replay.closed_loop import PlannerDriver
        from flylog.replay.config import ReplayConfig, load_replay_config

        config = load_replay_config(config_file) if config_file else ReplayConfig()

        def make_driver(scene, write):
            return PlannerDriver(config, scene.spec.camera, scene.start_pose, scene.goal, write)

    elif config_file is not None:
        raise click.UsageError("--config goes with --drive planner")
    with progress_bar(f"simulate {loaded.name}", unit="frames") as update:
        summary = run_simulation(loaded, output, options, make_driver=make_driver, on_frame=update)
    speed = summary.duration / summary.wall_seconds
    stdout.print(
        f"{summary.path}: {summary.frames} stereo frames, {summary.messages} messages, "
        f"{human_bytes(summary.bytes)}, {summary.duration:g} s simulated in "
        f"{summary.wall_seconds:.1f} s wall ({speed:.1f}× real time); "
        f"{summary.goal_distance:.2f} m from the goal"
        + (
            f"; planner {summary.status}, run ended by {summary.ending}"
            if summary.ending is not None
            else ""
        ),
        soft_wrap=True,
    )
