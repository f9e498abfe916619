"""``flylog simulate``: thin wrapper over :func:`flylog.sim.run.simulate`."""

from __future__ import annotations

from pathlib import Path

import click

from flylog.cli.common import (
    Finite,
    OutputPath,
    human_bytes,
    limit_options,
    principal_point,
    progress_bar,
    reports_errors,
    resolution,
    stdout,
)
from flylog.geometry.stereo import MAX_FRAME_RATE


@click.command()
@click.argument("scene", type=click.Path(dir_okay=False, path_type=Path))
@click.option(
    "-o",
    "--output",
    type=OutputPath(dir_okay=False, path_type=Path),
    required=True,
    help="Where to write the MCAP log (written atomically: nothing appears there on failure).",
)
@click.option(
    "--duration",
    type=Finite(min=0.0, min_open=True),
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
    type=Finite(min=0.1, max=MAX_FRAME_RATE),
    default=None,
    metavar="HZ",
    help=f"Stereo pairs per second, at most {MAX_FRAME_RATE:g}. [default: the scene's "
    "camera.frame_rate, 15 Hz]",
)
@click.option(
    "--tilt",
    type=Finite(-60.0, 60.0),
    default=None,
    metavar="DEG",
    help="Downward pitch of the cameras' optical axes in degrees. [default: the scene's "
    "camera.tilt, 0]",
)
@click.option(
    "--roll",
    type=Finite(-45.0, 45.0),
    default=None,
    metavar="DEG",
    help="Roll of the cameras about their optical axis in degrees (positive lowers the "
    "right camera). [default: the scene's camera.roll, 0]",
)
@click.option(
    "--principal-point",
    callback=principal_point,
    default=None,
    metavar="CX,CY",
    help="Left camera's principal point in pixels of the output resolution. [default: the "
    "scene's camera.principal_point, else the image centre ((W-1)/2, (H-1)/2)]",
)
@click.option(
    "--doffs",
    type=Finite(),
    default=None,
    metavar="PX",
    help="Right camera's principal point x minus the left's in pixels (disparity = "
    "f·B/Z − doffs). [default: the scene's camera.doffs, 0]",
)
@click.option(
    "--camera",
    "camera_model",
    type=click.Choice(["realistic", "ideal"]),
    default=None,
    help="The cameras' model, replacing the scene's [camera_defects] table: realistic "
    "(exposure, gain, drift, gamma, noise, vignetting and blur at their typical values) or "
    "ideal (the renderer's images as they are). [default: the scene's table, else ideal]",
)
@click.option(
    "--compression",
    type=click.Choice(["zstd", "lz4", "none"]),
    default="zstd",
    show_default=True,
    help="MCAP chunk compression (zstd: 0.55x the size of lz4's; lz4: 1.8x less CPU to write, "
    "for the fastest simulation).",
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
@limit_options
@reports_errors
def simulate(
    scene: Path,
    output: Path,
    duration: float | None,
    seed: int,
    resolution: tuple[int, int] | None,
    frame_rate: float | None,
    tilt: float | None,
    roll: float | None,
    principal_point: tuple[float, float] | None,
    doffs: float | None,
    camera_model: str | None,
    compression: str,
    drive: str,
    config_file: Path | None,
    max_output_size: int,
    max_memory: int,
) -> None:
    """Simulate the robot in SCENE and record stereo frames, sonar, odometry and ground
    truth as an MCAP log. SCENE is a TOML scene file or the name of a scene bundled with
    flylog: corridor, turn, near-obstacle, clutter, doorways.

    A job whose estimated output or peak memory is over --max-output-size or --max-memory
    is refused before it starts, with the estimate."""
    from flylog.budget import Limits
    from flylog.io.collisions import Role, check_outputs
    from flylog.io.writer import Compression, LogConfig
    from flylog.scene.bundled import resolve_scene
    from flylog.scene.load import load_scene
    from flylog.sim.camera_defects import CameraDefects, CameraPreset
    from flylog.sim.run import SimulationOptions
    from flylog.sim.run import simulate as run_simulation

    scene = resolve_scene(scene)
    check_outputs(
        [Role(scene, "the scene", "scene")]
        + ([Role(config_file, "the configuration", "config_file")] if config_file else []),
        [Role(output, "the log", "output")],
    )
    loaded = load_scene(scene)
    options = SimulationOptions(
        duration=duration,
        seed=seed,
        resolution=resolution,
        frame_rate=frame_rate,
        log=LogConfig(compression=Compression(compression)),
        limits=Limits(max_output_size=max_output_size, max_memory=max_memory),
        camera=tuple(
            (name, value)
            for name, value in (
                ("tilt", tilt),
                ("roll", roll),
                ("principal_point", principal_point),
                ("doffs", doffs),
            )
            if value is not None
        ),
        camera_defects=(
            None if camera_model is None else CameraDefects.preset(CameraPreset(camera_model))
        ),
    )
    make_driver = None
    if drive == "planner":
        from flylog.replay.closed_loop import planner_driver
        from flylog.replay.config import ReplayConfig, load_replay_config
        from flylog.replay.limits import check_closed_loop

        config = load_replay_config(config_file) if config_file else ReplayConfig()
        check_closed_loop(config, loaded, options)
        make_driver = planner_driver(config)

    elif config_file is not None:
        raise click.UsageError("--config goes with --drive planner")
    with progress_bar(f"simulate {loaded.name}", unit="frames", kernels=True) as update:
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
