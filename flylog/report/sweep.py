"""``flylog report DIR``: a sweep on one page: each main metric against each grid key, one
line per variant (mean over the cells that ran ok at each value, with their sample
standard deviation as error bars, the other grid keys pooled), then the results table."""

from __future__ import annotations

import math
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from flylog.report.html import Page, write_page

_TABLE_METRICS = (
    "precision",
    "recall",
    "f_score",
    "detection_latency_mean_s",
    "goal_reached",
    "min_clearance_m",
    "ate_m",
    "cell_wall_s",
)

PANELS_PER_ROW = 4
# Metrics that are shares (0 … 1): their axes span 0 … 1, so that 0.992 against 1.000 looks
# as small as it is; the others' axes start at 0.
_SHARES = frozenset({"precision", "recall", "f_score", "goal_reached"})


def _finite(rows: Sequence[Mapping[str, Any]], metric: str) -> list[float]:
    values = [r.get(metric) for r in rows if r["status"] == "ok"]
    out = []
    for v in values:
        if v is None or isinstance(v, str):
            continue
        x = float(v)
        if math.isfinite(x):
            out.append(x)
    return out


def varying_metrics(
    rows: Sequence[Mapping[str, Any]], metrics: Sequence[tuple[str, str]]
) -> tuple[list[tuple[str, str]], list[str]]:
    """The metrics worth a plot (they vary over the ok cells), and a note for each other one:
    a metric with one value in every cell (a replay's clearance is its log's) or none."""
    shown, notes = [], []
    inputs = list(dict.fromkeys(str(r["input"]) for r in rows))
    for metric, label in metrics:
        values = _finite(rows, metric)
        each = {i: _finite([r for r in rows if str(r["input"]) == i], metric) for i in inputs}
        if not values:
            notes.append(f"{label}: no value in any cell")
        elif max(values) == min(values):
            notes.append(f"{label}: {values[0]:.4g} in every cell")
        elif all(not v or max(v) == min(v) for v in each.values()):
            # a replay's path, clearance and drift are its log's: the same in every cell of
            # an input, whatever the configuration
            per = ", ".join(f"{Path(i).name} {v[0]:.4g}" for i, v in each.items() if v)
            notes.append(f"{label}: the input's own, the same in each of its cells ({per})")
        else:
            shown.append((metric, label))
    return shown, notes


def _ordered(values: Sequence[Any]) -> list[Any]:
    """Distinct values, sorted when they compare (numbers, strings), else as they come."""
    distinct = list(dict.fromkeys(values))
    try:
        return sorted(distinct)
    except TypeError:
        return distinct


def metric_lines(
    rows: Sequence[Mapping[str, Any]], key: str, metric: str
) -> dict[str, tuple[list[Any], np.ndarray, np.ndarray]]:
    """variant → (the key's values, mean and sd of ``metric`` at each) over ok cells."""
    from flylog.metrics.compare import mean_std

    ok = [r for r in rows if r["status"] == "ok"]
    xs = _ordered([r[key] for r in ok])
    out = {}
    for variant in dict.fromkeys(r["variant"] for r in ok):
        stats = [
            mean_std(r[metric] for r in ok if r["variant"] == variant and r[key] == x) for x in xs
        ]
        out[variant] = (xs, np.array([m for m, _ in stats]), np.array([s for _, s in stats]))
    return out


def _plot(
    path: Path, rows: Sequence[Mapping[str, Any]], key: str, metrics: Sequence[tuple[str, str]]
) -> Path:
    from flylog.experiments.plots import COLOURS, pyplot, save_figure

    plt = pyplot()
    columns = min(PANELS_PER_ROW, len(metrics))
    rows_n = math.ceil(len(metrics) / columns)
    fig, axes = plt.subplots(rows_n, columns, figsize=(3.6 * columns, 3.0 * rows_n), squeeze=False)
    for ax in axes.ravel()[len(metrics) :]:
        ax.axis("off")
    for ax, (metric, label) in zip(axes.ravel(), metrics, strict=False):
        for colour, (variant, (xs, mean, sd)) in zip(
            COLOURS * 4, metric_lines(rows, key, metric).items(), strict=False
        ):
            numeric = all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in xs)
            at = np.asarray(xs, dtype=float) if numeric else np.arange(len(xs), dtype=float)
            ax.errorbar(
                at, mean, yerr=sd, color=colour, marker="o", ms=4, lw=1.4, capsize=3, label=variant
            )
            if not numeric:
                ax.set_xticks(at, [str(x) for x in xs])
        ax.set_xlabel(key)
        ax.set_ylabel(label)
        ax.grid(True, linewidth=0.3)
        if metric in _SHARES:
            ax.set_ylim(0.0, 1.02)
        elif min(_finite(rows, metric), default=0.0) >= 0:
            ax.set_ylim(bottom=0.0)
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path)


def sweep_report(directory: Path, output: Path) -> Path:
    """Write the page of the sweep in ``directory`` (its results.parquet)."""
    from flylog.sweep.results import read_results, results_path
    from flylog.sweep.summary import MAIN_METRICS

    keys, rows = read_results(directory)
    ok = sum(r["status"] == "ok" for r in rows)
    page = Page(f"flylog sweep {Path(directory).resolve().name}")
    page.headline(*sweep_headline(rows, keys))
    page.note(f"{results_path(directory)}")
    shown, constant = varying_metrics(rows, MAIN_METRICS)
    with tempfile.TemporaryDirectory(prefix="flylog-report-") as tmp:
        for i, key in enumerate(keys if shown else ()):
            page.heading(f"Metrics against {key}")
            png = _plot(Path(tmp) / f"grid{i}.png", rows, key, shown)
            page.figure(
                png,
                f"Mean over the cells that ran ok at each value of {key} (inputs, seeds and "
                "the other grid keys pooled), ± one sample standard deviation; a line per "
                "variant.",
            )
    if not keys:
        page.note("The sweep has no grid: no plot against a grid key.")
    for note in constant:
        page.note(f"Not drawn, no configuration changes it: {note}.")
    page.heading("Results")
    # Columns with a value in some cell (no column of "—" only; "error" when a cell failed).
    metrics = [m for m in _TABLE_METRICS if any(r.get(m) is not None for r in rows)]
    errors = ok < len(rows)
    head = ["cell", "input", "variant", *keys, "seed", "status", *metrics]
    head += ["error"] if errors else []
    body = []
    for r in rows:
        row = [r["cell"], Path(str(r["input"])).name, r["variant"], *(r[k] for k in keys)]
        row += [r["seed"], r["status"], *(r[m] for m in metrics)]
        row += [(r["error"] or "").splitlines()[0] if r["error"] else None] if errors else []
        body.append(row)
    classes = ["failed" if r["status"] != "ok" else "" for r in rows]
    page.table(head, body, text_columns=3, row_classes=classes)
    return write_page(page, output)


def sweep_headline(rows: Sequence[Mapping[str, Any]], keys: Sequence[str]) -> tuple[str, str, str]:
    """What ran (cells, inputs, variants, grid), the best grid point by F-score in a
    sentence, and the key figures."""
    from flylog.sweep.summary import summarize

    ok = [r for r in rows if r["status"] == "ok"]
    inputs = sorted({Path(str(r["input"])).name for r in rows})
    variants = list(dict.fromkeys(r["variant"] for r in rows))
    seeds = sorted({r["seed"] for r in rows})
    what = (
        f"A sweep of {len(rows)} cells: {len(inputs)} input(s) ({', '.join(inputs)}) × "
        f"{len(variants)} variant(s) ({', '.join(map(str, variants))}) × "
        + (" × ".join(f"{k} ∈ {_ordered([r[k] for r in rows])}" for k in keys) or "no grid")
        + f" × {len(seeds)} seed(s); {len(ok)} ok, {len(rows) - len(ok)} failed."
    )
    points = [p for p in summarize(rows, keys) if p.ok and "f_score" in p.metrics]
    points = [p for p in points if math.isfinite(p.metrics["f_score"][0])]
    if not points:
        return what, "No cell ran to an F-score.", f"{len(ok)} of {len(rows)} cells ok"
    best = max(points, key=lambda p: p.metrics["f_score"][0])
    worst = min(points, key=lambda p: p.metrics["f_score"][0])
    name = ", ".join(f"{k} {v}" for k, v in best.key)
    f, sd = best.metrics["f_score"]
    verdict = (
        f"The best grid point by F-score is {name}: F {f:.2f} ± {sd:.2f} over {best.ok} cell(s)."
    )
    figures = (
        f"F-score from {worst.metrics['f_score'][0]:.2f} to {f:.2f} over {len(points)} grid points"
    )
    for metric, label in (("precision", "precision"), ("recall", "recall")):
        if metric in best.metrics:
            figures += f" · {label} at the best {best.metrics[metric][0]:.2f}"
    return what, verdict, figures
