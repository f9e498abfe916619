"""``flylog compare``: summary metrics of a candidate against a base, with tolerances, for CI.

Each side is one or several metrics summaries (several seeds, say); each metric is
compared through its mean over the side's runs (nulls skipped; booleans count as 0/1, so
``goal_reached`` compares the share of runs that reached the goal). A metric has a
direction (``higher`` or ``lower`` is better) and a tolerance: the candidate *regresses*
if its mean is worse than the base's by more than ``max(absolute, relative × |base mean|)``,
and also if it lacks a value the base has. Metrics without a tolerance are shown, never
judged. Tolerances: the defaults below, then a TOML file, then single overrides::

    [precision]            # one table per metric; fields missing keep their default
    absolute = 0.05
    [ate_m]
    direction = "lower"
    relative = 0.2
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any, NamedTuple

import numpy as np

from flylog.config import from_mapping, param, problems_message, read_toml, to_mapping
from flylog.errors import ConfigError
from flylog.metrics.provenance import PROVENANCE_COLUMNS, warn_if_mixed
from flylog.metrics.tables import SUMMARY_COLUMNS, read_summary


class Direction(enum.Enum):
    HIGHER = "higher"
    LOWER = "lower"


@dataclass(frozen=True)
class Tolerance:
    """How a metric is judged."""

    direction: Direction = param(Direction.HIGHER, help="which way is better")
    absolute: float = param(0.0, help="worsening allowed, in the metric's unit", min=0.0)
    relative: float = param(0.0, help="worsening allowed, as a share of |base mean|", min=0.0)

    def allowed(self, base: float) -> float:
        return max(self.absolute, self.relative * abs(base))


_HI, _LO = Direction.HIGHER, Direction.LOWER
DEFAULT_TOLERANCES: Mapping[str, Tolerance] = MappingProxyType(
    {
        "precision": Tolerance(_HI, absolute=0.02),
        "recall": Tolerance(_HI, absolute=0.02),
        "f_score": Tolerance(_HI, absolute=0.02),
        "median_depth_error": Tolerance(_LO, absolute=0.005),
        "nearest_error_m": Tolerance(_LO, absolute=0.05),
        "obstacles_detected": Tolerance(_HI),
        "detection_latency_mean_s": Tolerance(_LO, absolute=0.2),
        "goal_reached": Tolerance(_HI),
        "planner_goal_reached": Tolerance(_HI),
        "time_to_goal_s": Tolerance(_LO, relative=0.1),
        "min_clearance_m": Tolerance(_HI, absolute=0.05),
        "collisions": Tolerance(_LO),
        "ate_m": Tolerance(_LO, relative=0.1),
        "rpe_m": Tolerance(_LO, relative=0.1),
        # Speed is noisy on shared CI machines: only a large drop fails.
        "evaluations_per_s": Tolerance(_HI, relative=0.3),
    }
)


class Verdict(enum.Enum):
    OK = "ok"
    BETTER = "better"
    REGRESSION = "regression"
    MISSING = "missing"  # the candidate lacks a value the base has: a regression
    UNJUDGED = "-"  # no tolerance, or no base value


class MetricComparison(NamedTuple):
    name: str
    base_mean: float
    base_std: float
    candidate_mean: float
    candidate_std: float
    delta: float  # candidate − base
    allowed: float  # worsening allowed (NaN if unjudged)
    verdict: Verdict

    @property
    def regressed(self) -> bool:
        return self.verdict in (Verdict.REGRESSION, Verdict.MISSING)


class Comparison(NamedTuple):
    metrics: list[MetricComparison]
    n_base: int
    n_candidate: int

    @property
    def regressed(self) -> list[MetricComparison]:
        return [m for m in self.metrics if m.regressed]


def _value(v: Any) -> float:
    if v is None:
        return math.nan
    if isinstance(v, bool):
        return float(v)
    return float(v) if isinstance(v, (int, float)) else math.nan


def mean_std(values: Iterable[Any]) -> tuple[float, float]:
    """Mean and sample standard deviation (0 for a single value) of the non-null values."""
    x = np.array([_value(v) for v in values], dtype=float)
    x = x[np.isfinite(x)]
    if len(x) == 0:
        return math.nan, math.nan
    return float(x.mean()), float(x.std(ddof=1)) if len(x) > 1 else 0.0


def judge(base: float, candidate: float, tolerance: Tolerance | None) -> tuple[float, Verdict]:
    """(allowed worsening, verdict) of a candidate mean against a base mean."""
    if tolerance is None or math.isnan(base):
        return math.nan, Verdict.UNJUDGED
    allowed = tolerance.allowed(base)
    if math.isnan(candidate):
        return allowed, Verdict.MISSING
    worse = base - candidate if tolerance.direction is Direction.HIGHER else candidate - base
    # A relative margin of 1e-9 so that equal values written through floats compare equal.
    if worse > allowed + 1e-9 * max(1.0, abs(base)):
        return allowed, Verdict.REGRESSION
    if worse < -allowed - 1e-9 * max(1.0, abs(base)):
        return allowed, Verdict.BETTER
    return allowed, Verdict.OK


def metric_names(
    rows: Sequence[Mapping[str, Any]], tolerances: Mapping[str, Tolerance]
) -> list[str]:
    """Numeric summary columns in the schema's order, then any other judged or numeric
    column the summaries hold."""
    names = [c.name for c in SUMMARY_COLUMNS if c.name not in ("run", "log", *PROVENANCE_COLUMNS)]
    seen = set(names)
    for row in rows:
        for k, v in row.items():
            if k not in seen and (k in tolerances or isinstance(v, (int, float))):
                names.append(k)
                seen.add(k)
    for k in tolerances:
        if k not in seen:
            names.append(k)
            seen.add(k)
    present = {k for row in rows for k in row}
    return [n for n in names if n in present]


def compare_summaries(
    base: Sequence[Mapping[str, Any]],
    candidate: Sequence[Mapping[str, Any]],
    tolerances: Mapping[str, Tolerance] = DEFAULT_TOLERANCES,
) -> Comparison:
    """Compare summary rows (one dict per run) side by side."""
    if not base or not candidate:
        msg = "compare needs at least one base and one candidate summary"
        raise ConfigError(msg)
    out = []
    for name in metric_names([*base, *candidate], tolerances):
        b_mean, b_std = mean_std(row.get(name) for row in base)
        c_mean, c_std = mean_std(row.get(name) for row in candidate)
        allowed, verdict = judge(b_mean, c_mean, tolerances.get(name))
        out.append(
            MetricComparison(name, b_mean, b_std, c_mean, c_std, c_mean - b_mean, allowed, verdict)
        )
    return Comparison(out, len(base), len(candidate))


def compare_files(
    base: Sequence[Path],
    candidate: Sequence[Path],
    tolerances: Mapping[str, Tolerance] = DEFAULT_TOLERANCES,
) -> Comparison:
    """Compare metrics outputs (``-o`` paths or their ``.summary.parquet``); a
    ProvenanceWarning if the sides were scored against different logs or configurations."""
    base_rows = [read_summary(p) for p in base]
    candidate_rows = [read_summary(p) for p in candidate]
    warn_if_mixed(base_rows, candidate_rows)
    return compare_summaries(base_rows, candidate_rows, tolerances)


# The metrics a tolerance may be given for: the summary's numeric columns.
TOLERABLE = tuple(c.name for c in SUMMARY_COLUMNS if str(c.type) != "string")


def _unknown_metrics(names: Iterable[str]) -> list[str]:
    return [n for n in names if n not in TOLERABLE]


def _valid_names() -> str:
    return "valid metrics: " + ", ".join(TOLERABLE)


def tolerances_from_mapping(
    data: Mapping[str, Any], *, source: str, base: Mapping[str, Tolerance] = DEFAULT_TOLERANCES
) -> dict[str, Tolerance]:
    """``base`` with the per-metric tables of a TOML mapping applied field by field; every
    unknown metric and malformed table is reported at once."""
    out = dict(base)
    unknown = _unknown_metrics(data)
    problems = [f"unknown metric '{n}'" for n in unknown]
    for name, table in data.items():
        if name not in TOLERABLE:
            continue
        if not isinstance(table, Mapping):
            problems.append(f"field '{name}': expected a table (direction, absolute, relative)")
            continue
        merged = {**to_mapping(out.get(name, Tolerance())), **table}
        try:
            out[name] = from_mapping(Tolerance, merged, source=source, prefix=name)
        except ConfigError as exc:
            problems.append(str(exc).removeprefix(f"{source}: "))
    if problems:
        valid = f"; {_valid_names()}" if unknown else ""
        raise ConfigError(problems_message(source, problems) + valid)
    return out


def load_tolerances(
    path: Path, *, base: Mapping[str, Tolerance] = DEFAULT_TOLERANCES
) -> dict[str, Tolerance]:
    """The tolerances of a TOML file (see this module's docstring) over ``base``."""
    return tolerances_from_mapping(read_toml(path), source=str(path), base=base)


def override_tolerance(tolerances: Mapping[str, Tolerance], spec: str) -> dict[str, Tolerance]:
    """Apply ``NAME=0.05`` (absolute) or ``NAME=10%`` (relative) to ``tolerances``; the
    metric keeps its direction (``higher`` for a metric without a default)."""
    name, sep, value = spec.partition("=")
    name, value = name.strip(), value.strip()
    relative = value.endswith("%")
    try:
        number = float(value.removesuffix("%"))
    except ValueError:
        number = math.nan
    if not sep or not name or not (math.isfinite(number) and number >= 0):
        msg = (
            f"tolerance {spec!r}: expected NAME=VALUE or NAME=PERCENT% with a finite VALUE "
            "of at least 0, e.g. precision=0.05"
        )
        raise ConfigError(msg, parameter="tolerance_specs")
    if name not in TOLERABLE:
        msg = f"tolerance {spec!r}: unknown metric '{name}'; {_valid_names()}"
        raise ConfigError(msg, parameter="tolerance_specs")
    old = tolerances.get(name, Tolerance())
    new = (
        dataclasses.replace(old, absolute=0.0, relative=number / 100.0)
        if relative
        else dataclasses.replace(old, absolute=number, relative=0.0)
    )
    return {**tolerances, name: new}
