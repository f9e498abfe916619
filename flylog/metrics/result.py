"""What scoring a run gives (:class:`MetricsResult`, the rows of the three tables) and
what a run file says about itself (:class:`RunFacts`: its obstacle rule and statistics),
shared by the scene scoring, the image scoring and the confidence's calibration."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from typing import Any

from flylog.config import from_mapping
from flylog.errors import LogError
from flylog.fly.obstacles import ObstacleFlies
from flylog.io import contract
from flylog.io.reader import LogReader
from flylog.metrics.config import MetricsConfig


@dataclass(frozen=True)
class RunFacts:
    """What a run file says about itself (its ``flylog.replay`` metadata)."""

    rule: ObstacleFlies
    generations: int | None = None
    evaluations: int | None = None
    wall_seconds: float | None = None
    log_duration: float | None = None


@dataclass(frozen=True)
class MetricsResult:
    """Rows of the three tables (``flylog.metrics.tables`` documents the columns)."""

    snapshots: list[dict[str, Any]]
    obstacles: list[dict[str, Any]]
    summary: dict[str, Any]
    config: MetricsConfig
    # the confidence's reliability table (flylog.metrics.calibration.reliability), or none
    reliability: list[dict[str, Any]] = dataclasses.field(default_factory=list)


def _number(meta: dict[str, str], key: str, kind: type) -> Any:
    if key not in meta:
        return None
    try:
        return kind(float(meta[key])) if kind is int else float(meta[key])
    except ValueError:
        return None


def run_facts(reader: LogReader, config: MetricsConfig) -> RunFacts:
    """The obstacle rule and run statistics of a run file. A run without flylog's
    configuration, or whose ``[obstacles]`` table has no ``min_distinctness``, is scored by
    the paper's rule (no distinctness: its clouds carry none)."""
    meta = reader.metadata().get(contract.REPLAY_METADATA, {})
    rule = ObstacleFlies(min_distinctness=0.0)
    if "config" in meta:
        try:
            table = json.loads(meta["config"]).get("obstacles", {})
        except json.JSONDecodeError as exc:
            msg = f"{reader.path}: metadata {contract.REPLAY_METADATA}.config is not JSON ({exc})"
            raise LogError(msg) from None
        source = f"{reader.path}: metadata {contract.REPLAY_METADATA}.config"
        table = {"min_distinctness": 0.0, **table}
        rule = from_mapping(ObstacleFlies, table, source=source, prefix="obstacles")
    return RunFacts(
        rule=rule,
        generations=_number(meta, "generations", int),
        evaluations=_number(meta, "evaluations", int),
        wall_seconds=_number(meta, "wall_seconds", float),
        log_duration=_number(meta, "log_duration", float),
    )
