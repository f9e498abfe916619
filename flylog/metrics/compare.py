"""``flylog compare``: summary metrics of a candidate against a base, for CI, judged by a
statistical test and a tolerance together.

Each side is one or several metrics summaries (seeds); booleans count as 0/1. A metric has
a direction (``higher`` or ``lower`` is better) and a tolerance, the worsening allowed:
``max(absolute, relative × |base mean|)``. The shift candidate − base gets an exact
interval and the verdict of :mod:`flylog.metrics.judge` at significance ``alpha``: a
regression only when the worsening exceeds the tolerance with confidence 1 − alpha.

Which metrics are judged (:class:`MetricKind`): what the engine and planner make, by
default; wall-clock figures only with a tolerance given for them (a file or ``-t``, never
a default); and never a figure of the log rather than the run (in open loop, the robot
follows the log, so its path, clearance and odometric errors are the log's). Tolerances:
the defaults below, then a TOML file, then single overrides::

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
from flylog.metrics.judge import Direction, Judgement, Verdict, judge
from flylog.metrics.provenance import PROVENANCE_COLUMNS, warn_if_mixed
from flylog.metrics.tables import SUMMARY_COLUMNS, read_summary

__all__ = ["Direction", "Verdict"]

DEFAULT_ALPHA = 0.05


@dataclass(frozen=True)
class Tolerance:
    """How a metric is judged."""

    direction: Direction = param(Direction.HIGHER, help="which way is better")
    absolute: float = param(0.0, help="worsening allowed, in the metric's unit", min=0.0)
    relative: float = param(0.0, help="worsening allowed, as a share of |base mean|", min=0.0)

    def allowed(self, base: float) -> float:
        return max(self.absolute, self.relative * abs(base))


class MetricKind(enum.Enum):
    RUN = "run"  # made by the engine or the planner: judged with its tolerance
    WALL_CLOCK = "wall-clock"  # measures the machine: judged only with an explicit tolerance
    LOG = "log"  # the log's, not the run's (open loop): never judged


# Figures of the machine: they differ between two runs of the same cell.
WALL_CLOCK = ("wall_s", "metrics_wall_s", "evaluations_per_s", "cell_wall_s", "cell_cpu_s")
# Figures of the true or odometric trajectory and of what lay along it: in open loop the
# robot follows the log, so they are the log's, equal for every engine and configuration.
FROM_LOG_IN_OPEN_LOOP = (
    "duration_s",
    "log_duration_s",
    "obstacles",
    "obstacles_visible",
    "goal_reached",
    "time_to_goal_s",
    "final_goal_distance_m",
    "path_length_m",
    "min_clearance_m",
    "collisions",
    "ate_m",
    "rpe_m",
    "rpe_deg",
)

_HI, _LO = Direction.HIGHER, Direction.LOWER
# Which way is better, for every metric that has a better way (the default direction of a
# tolerance given for it).
DIRECTIONS: Mapping[str, Direction] = MappingProxyType(
    {
        **dict.fromkeys(("precision", "recall", "f_score", "obstacles_detected"), _HI),
        **dict.fromkeys(("goal_reached", "planner_goal_reached", "min_clearance_m"), _HI),
        **dict.fromkeys(("evaluations_per_s", "coverage", "sgbm_dense_density"), _HI),
        **dict.fromkeys(
            (
                "median_depth_error",
                "nearest_error_m",
                "detection_latency_mean_s",
                "detection_latency_max_s",
                "time_to_goal_s",
                "final_goal_distance_m",
                "collisions",
                "ate_m",
                "rpe_m",
                "rpe_deg",
                "disparity_error_median_px",
                "bad1",
                "bad2",
                "sgbm_dense_error_median_px",
                "sgbm_dense_bad1",
                "sgbm_dense_bad2",
                *(n for n in WALL_CLOCK if n != "evaluations_per_s"),
            ),
            _LO,
        ),
    }
)

# The run's metrics: the seed-to-seed sd of the default configuration over engine seeds
# 0-19 on 2 s of the bundled corridor and near-obstacle scenes at 320×240 (the larger of the
# two scenes), rounded up to 1, 2 or 5 × a power of ten (docs/metrics.md#comparing-runs). The
# trajectory's metrics (the run's only in closed loop) keep round figures: not measured.
DEFAULT_TOLERANCES: Mapping[str, Tolerance] = MappingProxyType(
    {
        "precision": Tolerance(_HI, absolute=0.005),  # sd 0.0041
        "recall": Tolerance(_HI, absolute=0.02),  # sd 0.0105
        "f_score": Tolerance(_HI, absolute=0.01),  # sd 0.0055
        "median_depth_error": Tolerance(_LO, absolute=0.0002),  # sd 0.00013
        "nearest_error_m": Tolerance(_LO, absolute=0.005),  # sd 0.0023
        "obstacles_detected": Tolerance(_HI, absolute=1.0),  # sd 0.50
        "detection_latency_mean_s": Tolerance(_LO, absolute=0.2),  # sd 0.13
        "planner_goal_reached": Tolerance(_HI),  # sd 0
        "goal_reached": Tolerance(_HI),
        "time_to_goal_s": Tolerance(_LO, relative=0.1),
        "min_clearance_m": Tolerance(_HI, absolute=0.05),
        "collisions": Tolerance(_LO),
        "ate_m": Tolerance(_LO, relative=0.1),
        "rpe_m": Tolerance(_LO, relative=0.1),
    }
)


def metric_kind(name: str, *, open_loop: bool) -> MetricKind:
    if name in WALL_CLOCK:
        return MetricKind.WALL_CLOCK
    if open_loop and name in FROM_LOG_IN_OPEN_LOOP:
        return MetricKind.LOG
    return MetricKind.RUN


class MetricComparison(NamedTuple):
    name: str
    kind: MetricKind
    base_mean: float
    base_std: float
    candidate_mean: float
    candidate_std: float
    judgement: Judgement

    @property
    def verdict(self) -> Verdict:
        return self.judgement.verdict

    @property
    def delta(self) -> float:
        """Difference of the means, candidate − base."""
        return self.candidate_mean - self.base_mean

    @property
    def regressed(self) -> bool:
        return self.judgement.regressed


class Comparison(NamedTuple):
    metrics: list[MetricComparison]
    n_base: int  # runs a side
    n_candidate: int
    paired: bool  # values paired by seed and input
    alpha: float
    open_loop: bool = False

    @property
    def regressed(self) -> list[MetricComparison]:
        return [m for m in self.metrics if m.regressed]


def _value(v: Any) -> float:
    if v is None:
        return math.nan
    if isinstance(v, bool):
        return float(v)
    return float(v) if isinstance(v, (int, float)) else math.nan


def values_of(rows: Iterable[Mapping[str, Any]], name: str) -> np.ndarray:
    """A column of summary rows as floats (NaN where null or not a number)."""
    return np.array([_value(row.get(name)) for row in rows], dtype=float)


def mean_std(values: Iterable[Any]) -> tuple[float, float]:
    """Mean and sample standard deviation (0 for a single value) of the non-null values."""
    x = np.array([_value(v) for v in values], dtype=float)
    x = x[np.isfinite(x)]
    if len(x) == 0:
        return math.nan, math.nan
    return float(x.mean()), float(x.std(ddof=1)) if len(x) > 1 else 0.0


def metric_names(
    rows: Sequence[Mapping[str, Any]], tolerances: Mapping[str, Tolerance]
) -> list[str]:
    """Numeric summary columns in the schema's order, then any other judged or numeric
    column the summaries hold; columns null in every row are left out."""
    names = [c.name for c in SUMMARY_COLUMNS if c.name not in ("run", "log", *PROVENANCE_COLUMNS)]
    seen = set(names)
    for row in rows:
        for k, v in row.items():
            if k not in seen and (k in tolerances or isinstance(v, (int, float))):
                names.append(k)
                seen.add(k)
    valued = {k for row in rows for k, v in row.items() if math.isfinite(_value(v))}
    return [n for n in names if n in valued]


def _unjudged(reason: str) -> Judgement:
    return Judgement(Verdict.UNJUDGED, reason, None, math.nan)


def compare_metric(
    name: str,
    base: np.ndarray,
    candidate: np.ndarray,
    tolerance: Tolerance | None,
    *,
    kind: MetricKind,
    paired: bool,
    alpha: float,
) -> MetricComparison:
    """One metric's comparison; ``paired``: ``base[i]`` and ``candidate[i]`` ran the same
    seed and input."""
    b_mean, b_std = mean_std(base)
    c_mean, c_std = mean_std(candidate)
    if kind is MetricKind.LOG:
        judgement = _unjudged("the log's figures in open loop")
    elif tolerance is None:
        why = "wall-clock, no tolerance given"
        judgement = _unjudged(why if kind is MetricKind.WALL_CLOCK else "no tolerance")
    else:
        judgement = judge(
            base,
            candidate,
            direction=tolerance.direction,
            allowed=tolerance.allowed(b_mean) if math.isfinite(b_mean) else math.nan,
            paired=paired,
            alpha=alpha,
        )
    return MetricComparison(name, kind, b_mean, b_std, c_mean, c_std, judgement)


def is_open_loop(rows: Iterable[Mapping[str, Any]]) -> bool:
    """Whether metrics summaries score replays of logs (open loop): a summary scored
    against another file than its run (a closed-loop log holds its run)."""
    return any(row.get("run") is not None and row.get("run") != row.get("log") for row in rows)


def compare_summaries(
    base: Sequence[Mapping[str, Any]],
    candidate: Sequence[Mapping[str, Any]],
    tolerances: Mapping[str, Tolerance] = DEFAULT_TOLERANCES,
    *,
    alpha: float = DEFAULT_ALPHA,
    paired: bool = False,
    open_loop: bool | None = None,
) -> Comparison:
    """Compare summary rows (one dict per run) side by side. ``paired``: ``base[i]`` and
    ``candidate[i]`` ran the same seed and input. ``open_loop`` None: from the rows."""
    if not base or not candidate:
        msg = "compare needs at least one base and one candidate summary"
        raise ConfigError(msg)
    if paired and len(base) != len(candidate):
        msg = f"paired sides need as many runs each, got {len(base)} and {len(candidate)}"
        raise ValueError(msg)
    if open_loop is None:
        open_loop = is_open_loop([*base, *candidate])
    out = [
        compare_metric(
            name,
            values_of(base, name),
            values_of(candidate, name),
            tolerances.get(name),
            kind=metric_kind(name, open_loop=open_loop),
            paired=paired,
            alpha=alpha,
        )
        for name in metric_names([*base, *candidate], tolerances)
    ]
    return Comparison(out, len(base), len(candidate), paired, alpha, open_loop)


def compare_files(
    base: Sequence[Path],
    candidate: Sequence[Path],
    tolerances: Mapping[str, Tolerance] = DEFAULT_TOLERANCES,
    *,
    alpha: float = DEFAULT_ALPHA,
) -> Comparison:
    """Compare metrics outputs (``-o`` paths or their ``.summary.parquet``), unpaired (a
    summary does not record its run's seed); a ProvenanceWarning if the sides were scored
    against different logs or configurations."""
    base_rows = [read_summary(p) for p in base]
    candidate_rows = [read_summary(p) for p in candidate]
    warn_if_mixed(base_rows, candidate_rows)
    return compare_summaries(base_rows, candidate_rows, tolerances, alpha=alpha)


# The metrics a tolerance may be given for: the summary's numeric columns and a sweep's
# wall and CPU time per cell.
TOLERABLE = (
    *(c.name for c in SUMMARY_COLUMNS if str(c.type) != "string"),
    "cell_wall_s",
    "cell_cpu_s",
)


def default_tolerance(name: str) -> Tolerance:
    """A metric's default tolerance, else one allowing no worsening in its direction."""
    found = DEFAULT_TOLERANCES.get(name)
    return found if found is not None else Tolerance(DIRECTIONS.get(name, _HI))


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
        merged = {**to_mapping(out.get(name, default_tolerance(name))), **table}
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
    metric keeps its direction (see ``DIRECTIONS``; ``higher`` for a metric without one)."""
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
    old = tolerances.get(name, default_tolerance(name))
    new = (
        dataclasses.replace(old, absolute=0.0, relative=number / 100.0)
        if relative
        else dataclasses.replace(old, absolute=number, relative=0.0)
    )
    return {**tolerances, name: new}
