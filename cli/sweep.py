"""``flylog sweep``: thin wrapper over :func:`flylog.sweep.runner.run_sweep`."""

from __future__ import annotations

import math
import signal
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import click

from flylog.budget import SWEEP_MAX_CELLS, SWEEP_MAX_OUTPUT_SIZE
from flylog.cli.common import (
    EXIT_INTERRUPTED,
    ByteSize,
    OutputPath,
    Terminated,
    human_bytes,
    reports_errors,
    stderr,
    stdout,
)

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


def _cells_kept(output: Path) -> int:
    """The cells of the sweep in ``output`` whose outputs are whole (their cell.json)."""
    from flylog.sweep.cells import RUNS_DIR

    return sum(1 for _ in (output / RUNS_DIR).glob("*/cell.json"))


def _pm(mean: float, sd: float, n: int) -> str:
    if math.isnan(mean):
        return "—"
    return f"{mean:.3g}" if n < 2 else f"{mean:.3g} ± {sd:.2g}"


@click.command()
@click.argument("spec", type=click.Path(dir_okay=False, path_type=Path))
@click.option(
    "-o",
    "--output",
    type=OutputPath(file_okay=False, path_type=Path),
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
    "--max-cells",
    type=click.IntRange(min=1),
    default=SWEEP_MAX_CELLS,
    show_default=True,
    metavar="N",
    help="Refuse a SPEC of more than N cells (inputs × variants × grid points × seeds), "
    "before anything is planned or written.",
)
@click.option(
    "--max-output-size",
    type=ByteSize(),
    default=SWEEP_MAX_OUTPUT_SIZE,
    metavar="SIZE",
    help="Refuse a sweep whose cells and simulated inputs would write more than SIZE "
    f"(estimated, e.g. 100G). [default: {human_bytes(SWEEP_MAX_OUTPUT_SIZE)}]",
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
    max_cells: int,
    max_output_size: int,
    seeds_text: str | None,
    config_file: Path | None,
) -> None:
    """Run the sweep SPEC (TOML: inputs × seeds × a grid of configuration keys × variants;
    see docs/sweep.md): each cell replays its log (or runs the closed loop) and scores it.
    Exit code 1 if any cell failed (the others still ran), 2 on a bad SPEC."""
    from flylog.cli.tables import print_fitted
    from flylog.sweep.executors import Backend
    from flylog.sweep.limits import SweepLimits
    from flylog.sweep.runner import SweepOptions, run_sweep
    from flylog.sweep.spec import load_spec, parse_seeds, with_overrides
    from flylog.sweep.summary import MAIN_METRICS, summarize

    limits = SweepLimits(max_cells=max_cells, max_output_size=max_output_size)
    options = SweepOptions(
        Backend(backend), workers=workers, address=address, force=force, limits=limits
    )
    seeds = None if seeds_text is None else parse_seeds(seeds_text)
    loaded = with_overrides(load_spec(spec), seeds=seeds, config=config_file)
    try:
        with _cells_bar() as update:
            result = run_sweep(loaded, output, options, on_progress=update)
    except (KeyboardInterrupt, Terminated) as exc:
        signum = exc.signum if isinstance(exc, Terminated) else signal.SIGINT
        how = (
            "interrupted"
            if signum == signal.SIGINT
            else f"stopped by {signal.Signals(signum).name}"
        )
        kept = _cells_kept(output)
        stderr.print(
            f"[red]{how}[/]: {kept} finished cell(s) kept under {output}/runs (the same "
            "command resumes the sweep); the cells running were stopped and their partial "
            "outputs removed; results.parquet was not written",
            soft_wrap=True,
        )
        sys.exit(EXIT_INTERRUPTED if signum == signal.SIGINT else 128 + signum)
    keys = result.spec.grid_keys
    header = ["variant", *keys, "cells ok", "failed", *(label for _, label in MAIN_METRICS)]
    rows = [
        [*(str(v) for _, v in point.key), str(point.ok), str(point.failed)]
        + [_pm(*point.metrics[m], point.ok) for m, _ in MAIN_METRICS]
        for point in summarize(result.rows, keys)
    ]
    print_fitted(
        stdout,
        f"sweep {spec.name}: mean ± sd per grid point",
        header,
        rows,
        right=range(1 + len(keys), len(header)),
        key_columns=1 + len(keys),
    )
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
