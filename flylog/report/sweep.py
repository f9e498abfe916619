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

_TABLE_METRICS = ("precision", "recall", "f_score", "detection_latency_mean_s",
                  "goal_reached", "min_clearance_m", "ate_m", "cell_wall_s")  # fmt: skip

PANELS_PER_ROW = 4


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
    from flylog.experiments.plots import COLOURS, _pyplot, _save

    plt = _pyplot()
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
            ax.errorbar(at, mean, yerr=sd, color=colour, marker="o", ms=4, lw=1.4, capsize=3,
                        label=variant)  # fmt: skip
            if not numeric:
                ax.set_xticks(at, [str(x) for x in xs])
        ax.set_xlabel(key)
        ax.set_ylabel(label)
        ax.grid(True, linewidth=0.3)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    return _save(fig, path)


def sweep_report(directory: Path, output: Path) -> Path:
    """Write the page of the sweep in ``directory`` (its results.parquet)."""
    from flylog.sweep.results import read_results, results_path
    from flylog.sweep.summary import MAIN_METRICS

    keys, rows = read_results(directory)
    ok = sum(r["status"] == "ok" for r in rows)
    page = Page(f"flylog sweep {Path(directory).resolve().name}")
    page.note(
        f"{results_path(directory)}: {len(rows)} cells, {ok} ok, {len(rows) - ok} failed; "
        f"grid keys: {', '.join(keys) or 'none'}"
    )
    with tempfile.TemporaryDirectory(prefix="flylog-report-") as tmp:
        for i, key in enumerate(keys):
            page.heading(f"Metrics against {key}")
            png = _plot(Path(tmp) / f"grid{i}.png", rows, key, MAIN_METRICS)
            page.figure(
                png,
                f"Mean over the cells that ran ok at each value of {key} (inputs, seeds and "
                "the other grid keys pooled), ± one sample standard deviation; a line per "
                "variant.",
            )
    if not keys:
        page.note("The sweep has no grid: no plot against a grid key.")
    page.heading("Results")
    head = ["cell", "input", "variant", *keys, "seed", "status", *_TABLE_METRICS, "error"]
    body = [
        [r["cell"], Path(str(r["input"])).name, r["variant"], *(r[k] for k in keys), r["seed"],
         r["status"], *(r[m] for m in _TABLE_METRICS),
         (r["error"] or "").splitlines()[0] if r["error"] else None]
        for r in rows
    ]  # fmt: skip
    classes = ["failed" if r["status"] != "ok" else "" for r in rows]
    page.table(head, body, text_columns=3, row_classes=classes)
    return write_page(page, output)
