"""``flylog compare`` of two sweeps: rows matched by grid point (variant and every grid
key's value); each point's cells that ran ok (inputs × seeds) are compared as the runs of
a summaries comparison. The sweeps must share their grid keys; a point found on one side
only is reported, not judged."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any, NamedTuple

from flylog.errors import ConfigError
from flylog.metrics.compare import DEFAULT_TOLERANCES, Tolerance, compare_summaries
from flylog.metrics.gate import Group
from flylog.sweep.results import METRIC_COLUMNS, TIMING_COLUMNS, read_results
from flylog.sweep.summary import group_rows
from flylog.sweep.work import STATUS_OK

# Columns that describe a cell, not what it measured: never compared.
_NOT_METRICS = ("cell", "input_seed", "seed", "duration_s", "obstacles", "log_duration_s")


class SweepComparison(NamedTuple):
    groups: list[Group]
    only_base: list[tuple[tuple[str, Any], ...]]  # grid points of the base alone
    only_candidate: list[tuple[tuple[str, Any], ...]]


def _metrics_only(row: Mapping[str, Any]) -> dict[str, Any]:
    names = {c.name for c in METRIC_COLUMNS} - set(_NOT_METRICS)
    return {k: v for k, v in row.items() if k in names or k in TIMING_COLUMNS}


def compare_results(
    base: Path,
    candidate: Path,
    tolerances: Mapping[str, Tolerance] = DEFAULT_TOLERANCES,
) -> SweepComparison:
    """Compare two sweeps' ``results.parquet`` point by point."""
    base_keys, base_rows = read_results(base)
    cand_keys, cand_rows = read_results(candidate)
    if base_keys != cand_keys:
        msg = (
            f"{candidate}: grid keys {cand_keys} differ from the base's {base_keys} "
            f"({base}): sweeps are compared point by point"
        )
        raise ConfigError(msg)
    b_groups, c_groups = group_rows(base_rows, base_keys), group_rows(cand_rows, cand_keys)
    groups = []
    for key, b_rows in b_groups.items():
        if key not in c_groups:
            continue
        c_rows = c_groups[key]
        b_ok = [_metrics_only(r) for r in b_rows if r["status"] == STATUS_OK]
        c_ok = [_metrics_only(r) for r in c_rows if r["status"] == STATUS_OK]
        if not b_ok:
            continue  # nothing to judge against
        # a point whose candidate cells all failed lacks every value: a regression
        comparison = compare_summaries(b_ok, c_ok or [{}], tolerances)
        if not c_ok:
            comparison = comparison._replace(n_candidate=0)
        groups.append(Group(key, comparison, len(b_rows) - len(b_ok), len(c_rows) - len(c_ok)))
    if not groups:
        msg = f"{base} and {candidate} share no grid point with a cell that ran ok"
        raise ConfigError(msg)
    return SweepComparison(
        groups,
        [k for k in b_groups if k not in c_groups],
        [k for k in c_groups if k not in b_groups],
    )
