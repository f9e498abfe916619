"""``flylog replay``: thin wrapper over :func:`flylog.replay.run.replay`."""

from __future__ import annotations

from pathlib import Path

import click

from flylog.cli.common import progress_bar, reports_errors, stdout
from flylog.cli.main import freeze_imported_objects


def _goal(ctx: click.Context, param: click.Parameter, value: str | None):
    if value is None:
        return None
    try:
        x, y = (float(p) for p in value.split(","))
    except ValueError:
        msg = f"expected X,Y in metres, e.g. 10,0.5, got {value!r}"
        raise click.BadParameter(msg) from None
    return (x, y)


@click.command()
@click.argument("log", type=click.Path(dir_okay=False, path_type=Path))
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, path_type=Path),
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
@click.option(
    "--engine",
    "stereo",
    type=click.Choice(["flies", "sgbm"]),
    default=None,
    help="Stereo engine: flies (the fly algorithm) or sgbm (the conventional pipeline: "
    "OpenCV StereoSGBM on complete frames, frame-synchronous, each frame costing "
    "sgbm.seconds_per_frame of log time, --flies points per frame, no sonar fusion). "
    "[default: flies]",
)
@click.option(
    "--seed",
    type=click.IntRange(min=0),
    default=None,
    metavar="N",
    help="Seed of the engine's random generator. [default: 0]",
)
@click.option(
    "--flies",
    type=click.IntRange(min=16),
    default=None,
    metavar="N",
    help="Population size. [default: 5000]",
)
@click.option(
    "--generations-per-frame",
    type=click.IntRange(min=0),
    default=None,
    metavar="N",
    help="Run exactly N generations per stereo pair (the paper's experiments use 1); 0 runs "
    "asynchronously, generations back to back on the newest data (a one-frame log, an "
    "imported pair: one frame period of virtual compute on it). [default: 0]",
)
@click.option(
    "--evals-per-second",
    type=click.FloatRange(min=1.0),
    default=None,
    metavar="X",
    help="Virtual compute budget in fitness evaluations per second: each generation costs "
    "its evaluations / X of log time (3.7 M/s: this engine on the 2-core reference "
    "machine, as SGBM's cost per frame). [default: 3700000]",
)
@click.option(
    "--sync",
    is_flag=True,
    default=None,
    help="Model the conventional pipeline of the paper's Table 1: process only complete "
    "frames, publish only when processing has ended. [default: off]",
)
@click.option(
    "--snapshot-rate",
    type=click.FloatRange(min=0.01),
    default=None,
    metavar="HZ",
    help="How often flies, potential and path are written. [default: 5 Hz]",
)
@click.option(
    "--goal",
    callback=_goal,
    default=None,
    metavar="X,Y",
    help="Goal in the odom frame, m. [default: the log's mission metadata]",
)
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
) -> None:
    """Replay LOG (an MCAP log from `flylog simulate`) through the fly engine (or the SGBM
    baseline) and the harmonic-function planner on a deterministic virtual clock. Never
    reads /truth/."""
    from flylog.config import replace_dotted
    from flylog.replay.config import ReplayConfig, Stereo, load_replay_config
    from flylog.replay.run import replay as run_replay

    freeze_imported_objects()

    config = load_replay_config(config_file) if config_file else ReplayConfig()
    overrides = {
        "seed": seed,
        "engine.flies": flies,
        "generations_per_frame": generations_per_frame,
        "evals_per_second": evals_per_second,
        "sync": sync,
        "snapshot_rate": snapshot_rate,
        # last: the cross-field check (sgbm runs one step per frame) sees the final options
        "stereo": Stereo(stereo) if stereo is not None else None,
    }
    try:
        config = replace_dotted(config, overrides)
    except ValueError as exc:  # a cross-field check, e.g. sgbm with several generations
        raise click.UsageError(str(exc)) from None
    with progress_bar(f"replay {log.name}", unit="s") as update:
        summary = run_replay(log, output, config, goal=goal, on_progress=update)
    speed = summary.log_duration / summary.wall_seconds
    if summary.stereo == Stereo.SGBM.value:
        work = f"{summary.generations} frames matched by SGBM"
    else:
        work = f"{summary.generations} generations, {summary.evaluations / 1e6:.2f} M evaluations"
    stdout.print(
        f"{summary.output} and {summary.table.name}: {summary.log_duration:g} s of log "
        f"replayed in {summary.wall_seconds:.1f} s ({speed:.1f}× real time), "
        f"{summary.frames} frames, {work}, {summary.snapshots} snapshots, "
        f"planner {summary.status}",
        soft_wrap=True,
    )
