"""``flylog compare`` of two sweeps: cells matched by grid point (variant and every grid
key's value) and input (by its file name and simulation seed, so that the sweeps of two
checkouts match; by its full path where two inputs of a sweep share a name). Within each,
the cells that ran ok are the runs of a summaries comparison, paired by engine seed when
both sides ran the same seeds (a side's seeds given with ``flylog sweep --seeds``),
unpaired otherwise. The sweeps must share their grid keys; a point or input found on one
side only is reported, not judged.

A cell whose input was damaged (the optional columns ``input_messages_lost`` and
``input_warnings``: messages the reader skipped, or its warnings) is named in the group's
``input_damage``: its figures stand, but the input is not what it should be."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

from flylog.errors import ConfigError
from flylog.metrics.compare import (
    DEFAULT_ALPHA,
    DEFAULT_TOLERANCES,
    Tolerance,
    compare_summaries,
)
from flylog.metrics.gate import Group
from flylog.sweep.results import METRIC_COLUMNS, TIMING_COLUMNS, read_results
from flylog.sweep.summary import point_key
from flylog.sweep.work import STATUS_OK

# Columns that describe a cell, not what it measured: never compared.
_NOT_METRICS = ("cell", "input_seed", "seed", "duration_s", "obstacles", "log_duration_s")
INPUT_KEY = "input"
CLOSED_LOOP = "closed_loop"

Key = tuple[tuple[str, Any], ...]


class SweepComparison(NamedTuple):
    groups: list[Group]
    only_base: list[Key]  # grid points and inputs of the base alone
    only_candidate: list[Key]


def _metrics_only(row: Mapping[str, Any]) -> dict[str, Any]:
    names = {c.name for c in METRIC_COLUMNS} - set(_NOT_METRICS)
    return {k: v for k, v in row.items() if k in names or k in TIMING_COLUMNS}


def input_name(label: str) -> str:
    """An input as two sweeps of different checkouts both name it: the file name of the
    log or scene, and the simulation seed (``corridor.toml@seed0``)."""
    path, at, seed = str(label).partition("@")
    return Path(path).name + at + seed


def _input_names(rows: Sequence[Mapping[str, Any]]) -> dict[str, str]:
    """Each input label's name, or the label itself where two inputs share a name."""
    labels = sorted({str(r["input"]) for r in rows})
    names = [input_name(label) for label in labels]
    if len(set(names)) < len(names):
        return {label: label for label in labels}
    return dict(zip(labels, names, strict=True))


def _grouped(rows: Sequence[Mapping[str, Any]], grid_keys: Sequence[str]) -> dict[Key, list]:
    """Rows by grid point and input (by name: the same log or scene in two checkouts)."""
    names = _input_names(rows)
    groups: dict[Key, list[Mapping[str, Any]]] = {}
    for row in rows:
        key = (*point_key(row, grid_keys), (INPUT_KEY, names[str(row["input"])]))
        groups.setdefault(key, []).append(row)
    return groups


def input_damage(side: str, rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """What the optional damage columns say about a side's cells (empty if nothing)."""
    out = []
    lost = [int(r.get("input_messages_lost") or 0) for r in rows]
    if any(lost):
        cells = sum(n > 0 for n in lost)
        out.append(f"{side}: {sum(lost)} input messages lost in {cells} of {len(rows)} cells")
    warnings = sorted({str(w) for r in rows if (w := r.get("input_warnings"))})
    out += [f"{side}: input warning: {w}" for w in warnings]
    return out


def _pairs(b_ok: list[Mapping[str, Any]], c_ok: list[Mapping[str, Any]], same_seeds: bool):
    """The ok cells in seed order on both sides when they pair (both sides ran the same
    seeds, each once, and each seed ran ok on both); else None."""
    if not same_seeds:
        return None
    by_b = {r["seed"]: r for r in b_ok}
    by_c = {r["seed"]: r for r in c_ok}
    if len(by_b) != len(b_ok) or len(by_c) != len(c_ok):
        return None
    seeds = sorted(set(by_b) & set(by_c))
    if not seeds:
        return None
    return [by_b[s] for s in seeds], [by_c[s] for s in seeds]


def compare_results(
    base: Path,
    candidate: Path,
    tolerances: Mapping[str, Tolerance] = DEFAULT_TOLERANCES,
    *,
    alpha: float = DEFAULT_ALPHA,
) -> SweepComparison:
    """Compare two sweeps' ``results.parquet`` grid point by grid point, input by input."""
    base_keys, base_rows = read_results(base)
    cand_keys, cand_rows = read_results(candidate)
    if base_keys != cand_keys:
        msg = (
            f"{candidate}: grid keys {cand_keys} differ from the base's {base_keys} "
            f"({base}): sweeps are compared point by point"
        )
        raise ConfigError(msg)
    b_groups, c_groups = _grouped(base_rows, base_keys), _grouped(cand_rows, cand_keys)
    groups = []
    for key, b_rows in b_groups.items():
        if key not in c_groups:
            continue
        c_rows = c_groups[key]
        b_ok = [r for r in b_rows if r["status"] == STATUS_OK]
        c_ok = [r for r in c_rows if r["status"] == STATUS_OK]
        if not b_ok:
            continue  # nothing to judge against
        open_loop = any(r.get("input_kind") != CLOSED_LOOP for r in b_rows)
        same_seeds = sorted(r["seed"] for r in b_rows) == sorted(r["seed"] for r in c_rows)
        pairs = _pairs(b_ok, c_ok, same_seeds) if c_ok else None
        b_side, c_side = pairs if pairs else (b_ok, c_ok)
        # a group whose candidate cells all failed lacks every value: a regression
        comparison = compare_summaries(
            [_metrics_only(r) for r in b_side],
            [_metrics_only(r) for r in c_side] or [{}],
            tolerances,
            alpha=alpha,
            paired=pairs is not None,
            open_loop=open_loop,
        )
        if not c_ok:
            comparison = comparison._replace(n_candidate=0)
        damage = input_damage("base", b_rows) + input_damage("candidate", c_rows)
        failed = (len(b_rows) - len(b_ok), len(c_rows) - len(c_ok))
        groups.append(Group(key, comparison, *failed, input_damage=tuple(damage)))
    if not groups:
        msg = f"{base} and {candidate} share no grid point and input with a cell that ran ok"
        raise ConfigError(msg)
    return SweepComparison(
        groups,
        [k for k in b_groups if k not in c_groups],
        [k for k in c_groups if k not in b_groups],
    )
