"""``flylog experiment``: thin wrapper over :func:`flylog.experiments.parallel.run_experiments`."""

from __future__ import annotations

from pathlib import Path

import click

from flylog.cli.common import Finite, OutputPath, progress_bar, reports_errors, resolution, stdout

QUICK_RESOLUTION = (160, 120)
QUICK_SEEDS = 2
DEFAULT_SEEDS = 5
OWN_DEFAULT_SEEDS = {"navigation": 30}  # worlds per family (flylog.experiments.navigation)


@click.command()
@click.argument("name", metavar="NAME")
@click.option(
    "-o",
    "--output",
    type=OutputPath(file_okay=False, path_type=Path),
    default=Path("experiments-out"),
    show_default=True,
    help="Directory to write into: each experiment writes DIR/NAME/summary.md (its table "
    "and plots), its PNGs and results.json (every run's figures).",
)
@click.option(
    "--seeds",
    type=click.IntRange(min=1, max=1000),
    default=None,
    metavar="N",
    help=f"Seeds per configuration, 0…N−1 (each simulates its own log and seeds the "
    f"engine); navigation: N passages and N clutter worlds, N/3 dead-end ones. [default: "
    f"{DEFAULT_SEEDS}, navigation 30; {QUICK_SEEDS} with --quick]",
)
@click.option(
    "--resolution",
    callback=resolution,
    default=None,
    metavar="WxH",
    help="Image size in pixels; the field of view stays the scene's. "
    "[default: 320x240; 160x120 with --quick]",
)
@click.option(
    "--duration",
    type=Finite(min=0.0, min_open=True),
    default=None,
    metavar="SECONDS",
    help="Simulated time of every log. [default: each experiment's scene durations: turn "
    "8 s, near-obstacle 5 s, corridor 30 s; the closed loop stops at the goal or after 180 s]",
)
@click.option(
    "--flies",
    type=click.IntRange(min=16, max=10_000_000),
    default=None,
    metavar="N",
    help="Population size. [default: the engine's, 5000]",
)
@click.option(
    "--quick",
    is_flag=True,
    help=f"A smaller run: {QUICK_RESOLUTION[0]}x{QUICK_RESOLUTION[1]} images and "
    f"{QUICK_SEEDS} seeds (an explicit --resolution or --seeds wins).",
)
@click.option(
    "--keep-logs",
    is_flag=True,
    help="Keep the sensor logs and runs (MCAP, about 100 MB per 30 s at 320x240) under "
    "DIR/NAME/runs/. [default: deleted once scored]",
)
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    metavar="N",
    help="Worker processes (flylog.sweep's process pool) that run the experiments' cells, "
    "one (scene, seed) each, the longest first; each worker gets cores / N numba threads. "
    "The results do not depend on N. [default: the cores this process may use]",
)
@reports_errors
def experiment(
    name: str,
    output: Path,
    seeds: int | None,
    resolution: tuple[int, int] | None,
    duration: float | None,
    flies: int | None,
    quick: bool,
    keep_logs: bool,
    workers: int | None,
) -> None:
    """Run one of the paper's experiments (or all) over several seeds and write a Markdown
    summary with a table and PNG plots.

    NAME is one of: proprioception (on/off on turn, one generation per frame: Fig. 4/5),
    sonar (fusion on/off on near-obstacle: Fig. 9), latency (async vs --sync vs SGBM:
    detection latency and planner reaction, Table 1), closed-loop (obstacle avoidance on
    corridor and clutter: Fig. 7/8), navigation (generated passages, clutter and dead-end
    worlds, one closed-loop run each), all.
    """
    from flylog.experiments import EXPERIMENTS, experiment_names
    from flylog.experiments.common import ExperimentOptions
    from flylog.experiments.parallel import run_experiments
    from flylog.sweep.executors import default_workers

    names = experiment_names(name)
    options = ExperimentOptions(
        seeds=seeds or (QUICK_SEEDS if quick else OWN_DEFAULT_SEEDS.get(name, DEFAULT_SEEDS)),
        resolution=resolution or (QUICK_RESOLUTION if quick else (320, 240)),
        duration=duration,
        flies=flies,
        keep_logs=keep_logs,
    )
    # The bar counts the cells' expected work, log seconds simulated and replayed: its ETA
    # weighs each cell by its length (flylog.experiments.parallel.run_plans).
    with progress_bar(f"experiment {', '.join(names)}", unit="log s") as update:
        results = run_experiments(
            names, output, options, workers=workers or default_workers(), on_progress=update
        )
    for one, result in zip(names, results, strict=True):
        _print_result(result, EXPERIMENTS[one][2])


def _print_result(result, description: str) -> None:
    from flylog.cli.tables import print_fitted
    from flylog.experiments.common import format_cell

    columns = result.table.columns
    rows = [[format_cell(row.get(c.key), c.fmt) for c in columns] for row in result.table.rows]
    print_fitted(
        stdout,
        f"{result.name}: {result.table.title}",
        [c.header for c in columns],
        rows,
        right=range(1, len(columns)),
    )
    for line in result.findings:
        stdout.print(f"- {line}", soft_wrap=True)
    stdout.print(
        f"{description}: {result.summary} and {len(result.figures)} figures", soft_wrap=True
    )
