"""What every experiment shares: options, the result it returns, running simulate → replay →
metrics for one seed, and statistics over seeds.

An experiment writes into ``DIR/NAME/``: ``summary.md`` (the table and the plots),
PNGs, ``results.json`` (every run's figures, then the table), and its sensor logs and runs
under ``runs/`` (deleted after scoring unless ``keep_logs``: they are large).
"""

from __future__ import annotations

import json
import math
import shutil
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from flylog.config import param, to_mapping
from flylog.errors import ConfigError
from flylog.io.atomic import write_text
from flylog.scene.bundled import scenes_dir

CHECKOUT = Path(__file__).resolve().parents[2]
SCENES = scenes_dir()

Progress = Callable[[float, float], None]


@dataclass(frozen=True)
class ExperimentOptions:
    """How big an experiment runs; each experiment has its own scene durations."""

    seeds: int = param(5, help="seeds per configuration: 0 … N−1", min=1, max=1000)
    resolution: tuple[int, int] = param(
        (320, 240), help="image width and height (the field of view stays the scene's)", unit="px"
    )
    duration: float | None = param(
        None,
        help="simulated time of every log; None: each experiment's own (the scene's, or "
        "what the experiment needs)",
        unit="s",
    )
    flies: int | None = param(None, help="population size; None: the engine's default")
    keep_logs: bool = param(False, help="keep the sensor logs and runs (MCAP) under runs/")
    scenes: Path = param(SCENES, help="directory of the scene files")

    def __post_init__(self) -> None:
        w, h = self.resolution
        if w < 16 or h < 16:
            msg = f"images must be at least 16x16 pixels, got {w}x{h}"
            raise ConfigError(msg)
        if self.duration is not None and self.duration <= 0:
            msg = f"duration must be positive, got {self.duration} s"
            raise ConfigError(msg)

    def scene_path(self, name: str) -> Path:
        path = self.scenes / f"{name}.toml"
        if not path.is_file():
            msg = f"{path}: no such scene file (flylog's bundled scenes are in {SCENES})"
            raise ConfigError(msg)
        return path

    def duration_or(self, default: float) -> float:
        return default if self.duration is None else self.duration


class Spread(NamedTuple):
    """A figure over seeds: mean, sample standard deviation, and how many runs gave it."""

    mean: float
    std: float
    n: int


def spread(values: Sequence[float]) -> Spread:
    """Mean and sample standard deviation of the finite values (NaN if there are none)."""
    v = np.asarray([x for x in values if x is not None], dtype=float)
    v = v[np.isfinite(v)]
    if len(v) == 0:
        return Spread(math.nan, math.nan, 0)
    std = float(v.std(ddof=1)) if len(v) > 1 else 0.0
    return Spread(float(v.mean()), std, len(v))


class Count(NamedTuple):
    """k of n runs (e.g. goal reached)."""

    k: int
    n: int


@dataclass(frozen=True)
class Column:
    key: str
    header: str
    fmt: str = ".3f"  # format of the numbers; Spread → "mean ± std"


@dataclass(frozen=True)
class Table:
    title: str
    columns: tuple[Column, ...]
    rows: tuple[dict[str, Any], ...]


def format_cell(value: Any, fmt: str) -> str:
    """A table cell as text: Spread as ``mean ± std``, Count as ``k/n``, NaN as ``–``."""
    if isinstance(value, Spread):
        if value.n == 0:
            return "–"
        return f"{value.mean:{fmt}} ± {value.std:{fmt}}" if value.n > 1 else f"{value.mean:{fmt}}"
    if isinstance(value, Count):
        return f"{value.k}/{value.n}"
    if isinstance(value, bool) or value is None:
        return str(value)
    if isinstance(value, float):
        return "–" if math.isnan(value) else f"{value:{fmt}}"
    return str(value)


@dataclass(frozen=True)
class ExperimentResult:
    """What an experiment returns: its table, the files it wrote and the per-run figures."""

    name: str
    table: Table
    summary: Path
    figures: tuple[Path, ...]
    runs: tuple[dict[str, Any], ...]  # one per (configuration, seed): plain numbers
    findings: tuple[str, ...] = field(default=())  # one-line measured facts


def experiment_dir(out_dir: Path, name: str) -> Path:
    path = out_dir / name
    (path / "runs").mkdir(parents=True, exist_ok=True)
    return path


def _plain(value: Any) -> Any:
    if isinstance(value, Spread):
        return {"mean": value.mean, "std": value.std, "n": value.n}
    if isinstance(value, Count):
        return {"k": value.k, "n": value.n}
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return _plain(value.item())
    if isinstance(value, Path):
        return str(value)
    return value


def _in_checkout(value: Any) -> Any:
    if isinstance(value, Path) and value.resolve().is_relative_to(CHECKOUT):
        return value.resolve().relative_to(CHECKOUT)
    return value


def write_results(
    path: Path, options: ExperimentOptions, table: Table, runs: Sequence[dict[str, Any]]
) -> Path:
    """``results.json``: the options, every run's figures and the table, as plain JSON. A
    scene directory inside flylog's checkout is written relative to it, so the file is the
    same wherever the checkout lies."""
    data = {
        "options": {k: _plain(_in_checkout(v)) for k, v in to_mapping(options).items()},
        "runs": [{k: _plain(v) for k, v in r.items()} for r in runs],
        "table": [{k: _plain(v) for k, v in r.items()} for r in table.rows],
    }
    out = path / "results.json"
    write_text(out, json.dumps(data, indent=1, default=str))
    return out


def discard_logs(path: Path, options: ExperimentOptions) -> None:
    """Remove ``runs/`` unless the options keep the logs."""
    if not options.keep_logs:
        shutil.rmtree(path / "runs", ignore_errors=True)
