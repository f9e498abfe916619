"""A sweep's rows grouped by grid point (variant and grid values): the mean and sample
standard deviation of each main metric over the point's cells (inputs × seeds)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

from flylog.metrics.compare import mean_std
from flylog.sweep.work import STATUS_OK

# What the summary table shows: (column, label)
MAIN_METRICS = (
    ("precision", "precision"),
    ("recall", "recall"),
    ("f_score", "F-score"),
    ("detection_latency_mean_s", "latency (s)"),
    ("goal_reached", "goal reached"),
    ("min_clearance_m", "clearance (m)"),
    ("ate_m", "ATE (m)"),
)

MAIN_METRIC_NAMES = tuple(name for name, _ in MAIN_METRICS)


class PointSummary(NamedTuple):
    """One grid point: its key values, how many cells ran ok and failed, metric → (mean, sd)."""

    key: tuple[tuple[str, Any], ...]  # ("variant", name), then each grid key and its value
    ok: int
    failed: int
    metrics: dict[str, tuple[float, float]]


def point_key(row: Mapping[str, Any], grid_keys: Sequence[str]) -> tuple[tuple[str, Any], ...]:
    return (("variant", row["variant"]), *((k, row[k]) for k in grid_keys))


def group_rows(
    rows: Sequence[Mapping[str, Any]], grid_keys: Sequence[str]
) -> dict[tuple[tuple[str, Any], ...], list[Mapping[str, Any]]]:
    """Rows by grid point, in the order points first appear."""
    groups: dict[tuple[tuple[str, Any], ...], list[Mapping[str, Any]]] = {}
    for row in rows:
        groups.setdefault(point_key(row, grid_keys), []).append(row)
    return groups


def summarize(
    rows: Sequence[Mapping[str, Any]],
    grid_keys: Sequence[str],
    metrics: Sequence[str] = MAIN_METRIC_NAMES,
) -> list[PointSummary]:
    """Mean ± sd of ``metrics`` per grid point, over the point's cells that ran ok."""
    out = []
    for key, group in group_rows(rows, grid_keys).items():
        ok = [r for r in group if r["status"] == STATUS_OK]
        stats = {m: mean_std(r.get(m) for r in ok) for m in metrics}
        out.append(PointSummary(key, len(ok), len(group) - len(ok), stats))
    return out
