"""``flylog sweep``: thin wrapper over :func:`flylog.sweep.runner.run_sweep`."""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import click

from flylog.cli.common import EXIT_INTERRUPTED, reports_errors, stderr, stdout

EXIT_FAILED_CELLS = 1


@contextmanager
def _cells_bar() -> Iterator[Callable[[Any], None]]:
    """A bar of cells done, with failed and running counts and an ETA (on a terminal)."""
    if not stderr.is_terminal:
        yield lambda progress: None
        return
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    columns = (
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[state]}"),
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
    )
    with Progress(*columns, console=stderr) as bar:
        tasks: dict[str, Any] = {}

        def update(p: Any) -> None:
            if p.phase not in tasks:
                name = "simulate inputs" if p.phase == "inputs" else "sweep cells"
                tasks[p.phase] = bar.add_task(name, total=p.total, state="")
            state = f"{p.failed} failed, {p.running} running"
            bar.update(tasks[p.phase], completed=p.done, total=p.total, state=state)

        yield update


def _pm(mean: float, sd: float, n: int) -> str:
    if math.isnan(mean):
        return "—"
    return f"{mean:.3g}" if n < 2 else f"{mean:.3g} ± {sd:.2g}"


@click.command()
@click.argument("spec", type=click.Path(dir_okay=False, path_type=Path))
@click.option(
    "-o",
    "--output",
    type=click.Path(file_okay=False, path_type=Path),
    required=True,
    help="Directory of the sweep: results.parquet (one row per cell), runs/ (each cell's "
    "run, its table and metrics), inputs/ (simulated logs). Running again into the same "
    "directory runs only the cells whose fingerprint changed or that failed.",
)
@click.option(
    "--backend",
    type=click.Choice(["processes", "ray"]),
    default="processes",
    show_default=True,
    help="processes: a local process pool; ray: Ray tasks, on the cluster at --address or "
    "a local one (pip install 'flylog[ray]'). Ray's workers read inputs and write outputs "
    "by path: on a cluster, every node needs them at the same paths (shared storage).",
)
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    metavar="N",
    help="Cells run at once (a local Ray cluster gets N CPUs). [default: the cores this "
    "process may use]",
)
@click.option(
    "--address",
    default=None,
    metavar="ADDR",
    help="With --backend ray: the Ray cluster to join (e.g. ray://head:10001). "
    "[default: $RAY_ADDRESS, else a new local cluster]",
)
@click.option(
    "--force", is_flag=True, help="Run every cell (and simulate every input) again. [default: off]"
)
@click.option(
    "--seeds",
    "seeds_text",
    default=None,
    metavar="SEEDS",
    help="The engine seeds instead of the spec's: N (0 … N−1), A-B, or a list such as "
    "0,3,10-14. One side of an A/B comparison: run the same spec for the base and the "
    "candidate, each with its seeds (the same seeds pair the cells). [default: the spec's]",
)
@click.option(
    "--config",
    "config_file",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    metavar="FILE",
    help="Replay configuration (TOML, as `flylog replay --config`) instead of the spec's "
    "`config`, under its variants and grid: the same spec for a base and a candidate "
    "configuration. [default: the spec's]",
)
@reports_errors
def sweep(
    spec: Path,
    output: Path,
    backend: str,
    workers: int | None,
    address: str | None,
    force: bool,
    seeds_text: str | None,
    config_file: Path | None,
) -> None:
    """Run the sweep SPEC (TOML: inputs × seeds × a grid of configuration keys × variants;
    see docs/sweep.md): each cell replays its log (or runs the closed loop) and scores it.
    Exit code 1 if any cell failed (the others still ran), 2 on a bad SPEC."""
    from rich.table import Table

    from flylog.sweep.executors import Backend
    from flylog.sweep.runner import SweepOptions, run_sweep
    from flylog.sweep.spec import load_spec, parse_seeds, with_overrides
    from flylog.sweep.summary import MAIN_METRICS, summarize

    options = SweepOptions(Backend(backend), workers=workers, address=address, force=force)
    seeds = None if seeds_text is None else parse_seeds(seeds_text)
    loaded = with_overrides(load_spec(spec), seeds=seeds, config=config_file)
    try:
        with _cells_bar() as update:
            result = run_sweep(loaded, output, options, on_progress=update)
    except KeyboardInterrupt:
        stderr.print(
            f"[red]interrupted[/]: the cells finished so far are kept under {output}/runs "
            "(the same command resumes the sweep); results.parquet was not written",
            soft_wrap=True,
        )
        sys.exit(EXIT_INTERRUPTED)
    keys = result.spec.grid_keys
    table = Table(title=f"sweep {spec.name}: mean ± sd per grid point", title_justify="left")
    for name in ("variant", *keys, "cells ok", "failed"):
        table.add_column(name)
    for _, label in MAIN_METRICS:
        table.add_column(label, justify="right")
    for point in summarize(result.rows, keys):
        values = [str(v) for _, v in point.key]
        stats = [_pm(*point.metrics[m], point.ok) for m, _ in MAIN_METRICS]
        table.add_row(*values, str(point.ok), str(point.failed), *stats)
    stdout.print(table)
    stdout.print(
        f"{result.results}: {len(result.rows)} cells ({result.ran} run, {result.reused} "
        f"already done) in {result.wall_seconds:.1f} s",
        soft_wrap=True,
    )
    if result.failed:
        for row in result.failed:
            first = (row["error"] or "").splitlines()[0] if row["error"] else "?"
            stderr.print(f"[red]failed:[/] cell {row['cell']} ({row['run_dir']}): {first}",
                         soft_wrap=True)  # fmt: skip
        sys.exit(EXIT_FAILED_CELLS)
