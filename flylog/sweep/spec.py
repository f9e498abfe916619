"""A sweep's SPEC.toml: its inputs, engine seeds, grid of configuration keys and variants.

Every mistake of a file is reported at once (one ConfigError, one line each), so that a
spec is fixed in one go. Paths are relative to the spec's directory. ``docs/sweep.md``
describes the format; ``fixtures/sweeps/example.toml`` is an example.
"""

from __future__ import annotations

import dataclasses
import enum
import glob
import itertools
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

from flylog.config import from_mapping, read_toml, replace_dotted
from flylog.errors import ConfigError, LimitError
from flylog.metrics.config import MetricsConfig
from flylog.replay.config import ReplayConfig, load_replay_config
from flylog.sweep.overrides import convert_value, flatten

T = TypeVar("T")

TOP_KEYS = ("logs", "simulate", "seeds", "config", "grid", "variants", "metrics")
SIMULATE_KEYS = ("scene", "duration", "resolution", "frame_rate", "seeds", "drive")
DEFAULT_VARIANT = "default"
# Keys a grid or a variant may not set: the engine seed is the sweep's own axis.
RESERVED = ("seed",)


class Drive(enum.Enum):
    PLAN = "plan"  # the scene's driving plan; every cell replays the log
    PLANNER = "planner"  # closed loop: each cell simulates with the engine and planner driving


@dataclass(frozen=True)
class SimulateInput:
    """A ``[[simulate]]`` entry: logs made by ``flylog simulate`` for each of ``seeds``."""

    scene: Path
    seeds: tuple[int, ...]
    drive: Drive = Drive.PLAN
    duration: float | None = None  # s; None: the scene's
    resolution: tuple[int, int] | None = None  # px; None: the scene's camera
    frame_rate: float | None = None  # Hz; None: the scene's camera


@dataclass(frozen=True)
class Variant:
    """A named set of configuration overrides (dotted keys, converted values)."""

    name: str
    overrides: tuple[tuple[str, Any], ...] = ()


@dataclass(frozen=True)
class SweepSpec:
    source: Path
    logs: tuple[Path, ...]
    simulate: tuple[SimulateInput, ...]
    seeds: tuple[int, ...]
    grid: tuple[tuple[str, tuple[Any, ...]], ...]  # dotted key → its values, in file order
    variants: tuple[Variant, ...]
    base: ReplayConfig
    metrics: MetricsConfig

    @property
    def grid_keys(self) -> tuple[str, ...]:
        return tuple(k for k, _ in self.grid)

    def grid_points(self) -> Iterator[tuple[tuple[str, Any], ...]]:
        """Every combination of the grid's values (one empty point without a grid)."""
        keys = self.grid_keys
        for values in itertools.product(*(v for _, v in self.grid)):
            yield tuple(zip(keys, values, strict=True))

    def config(self, variant: Variant, point: tuple[tuple[str, Any], ...], seed: int):
        """The effective replay configuration of a cell: base, variant, grid point, seed."""
        config = replace_dotted(self.base, dict(variant.overrides))
        config = replace_dotted(config, dict(point))
        return replace_dotted(config, {"seed": seed})


class _Problems:
    """Mistakes gathered while a spec is read; ``checked`` runs a step and keeps its error."""

    def __init__(self, source: Path) -> None:
        self.source = source
        self.lines: list[str] = []

    def add(self, message: str) -> None:
        self.lines.append(message)

    def checked(self, step: Callable[[], T]) -> T | None:
        try:
            return step()
        except ConfigError as exc:
            self.lines.extend(str(exc).splitlines())
            return None


# The largest seed: results.parquet holds seeds as int64 (numpy takes larger ones).
MAX_SEED = 2**63 - 1


def _is_seed(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value <= MAX_SEED


def _seeds(value: Any, where: str, problems: _Problems) -> tuple[int, ...]:
    """A list of seeds, or N for 0 … N−1."""
    if _is_seed(value) and value >= 1:
        return tuple(range(value))
    ok = isinstance(value, list) and len(value) > 0 and all(_is_seed(s) for s in value)
    if not ok or len(set(value)) != len(value):
        problems.add(
            f"{problems.source}: field '{where}': expected a list of distinct seeds "
            f"(integers from 0 to 2**63 - 1) or a count N ≥ 1 for 0 … N−1, got {value!r}"
        )
        return ()
    return tuple(value)


def _logs(value: Any, here: Path, problems: _Problems) -> tuple[Path, ...]:
    if not isinstance(value, list) or not all(isinstance(p, str) for p in value):
        problems.add(f"{problems.source}: field 'logs': expected a list of paths or globs")
        return ()
    found: list[Path] = []
    for pattern in value:
        full = str(here / pattern)
        matches = sorted(glob.glob(full)) if glob.has_magic(pattern) else [full]
        matches = [m for m in matches if Path(m).is_file()]
        if not matches:
            problems.add(
                f"{problems.source}: field 'logs': {pattern!r} names no file (relative to {here})"
            )
        found += [Path(m).resolve() for m in matches if Path(m).resolve() not in found]
    return tuple(found)


def _check_simulation_size(
    scene: Path, duration: Any, res: Any, frame_rate: Any, where: str, problems: _Problems
) -> None:
    """A simulation over the output or memory limits of ``flylog simulate`` is the spec's
    mistake (a ``duration = 1e9``), found before any cell runs."""
    from flylog.budget import DEFAULT_LIMITS
    from flylog.scene.load import load_scene
    from flylog.sim.run import SimulationOptions, simulation_budget

    options = SimulationOptions(
        duration=None if duration is None else float(duration),
        resolution=None if res is None else (res[0], res[1]),
        frame_rate=None if frame_rate is None else float(frame_rate),
    )
    try:
        simulation_budget(load_scene(scene), options).check(DEFAULT_LIMITS)
    except LimitError as exc:
        problems.add(f"{problems.source}: field '{where}': {exc}")
    except ConfigError:  # the scene's own mistakes are reported where it is loaded
        pass


def _simulate(entry: Any, i: int, here: Path, problems: _Problems) -> SimulateInput | None:
    where = f"simulate[{i}]"
    src = problems.source
    if not isinstance(entry, Mapping):
        problems.add(f"{src}: field '{where}': expected a table ([[simulate]])")
        return None
    n = len(problems.lines)
    for key in sorted(set(entry) - set(SIMULATE_KEYS)):
        problems.add(
            f"{src}: unknown field '{where}.{key}'; expected one of: {', '.join(SIMULATE_KEYS)}"
        )
    scene = entry.get("scene")
    if not isinstance(scene, str):
        problems.add(f"{src}: field '{where}.scene': expected the path of a scene file")
    else:
        from flylog.scene.load import load_scene

        problems.checked(lambda: load_scene(here / scene))
    seeds = _seeds(entry.get("seeds", [0]), f"{where}.seeds", problems)
    drive = entry.get("drive", Drive.PLAN.value)
    if drive not in [d.value for d in Drive]:
        problems.add(f"{src}: field '{where}.drive': expected 'plan' or 'planner', got {drive!r}")
    duration, frame_rate = entry.get("duration"), entry.get("frame_rate")
    for key, number in (("duration", duration), ("frame_rate", frame_rate)):
        if number is not None and (
            isinstance(number, bool) or not isinstance(number, (int, float)) or number <= 0
        ):
            problems.add(
                f"{src}: field '{where}.{key}': expected a positive number, got {number!r}"
            )
    res = entry.get("resolution")
    if res is not None and not (
        isinstance(res, list) and len(res) == 2 and all(isinstance(v, int) and v >= 16 for v in res)
    ):
        problems.add(
            f"{src}: field '{where}.resolution': expected [width, height], at least 16 px "
            f"each, got {res!r}"
        )
    if len(problems.lines) > n:
        return None
    _check_simulation_size(here / str(scene), duration, res, frame_rate, where, problems)
    if len(problems.lines) > n:
        return None
    return SimulateInput(
        scene=(here / str(scene)).resolve(),
        seeds=seeds,
        drive=Drive(drive),
        duration=None if duration is None else float(duration),
        resolution=None if res is None else (res[0], res[1]),
        frame_rate=None if frame_rate is None else float(frame_rate),
    )


def _converter(key: str, value: Any, source: str) -> Callable[[], Any]:
    return lambda: convert_value(ReplayConfig, key, value, source=source)


def _overrides(
    table: Mapping[str, Any], where: str, problems: _Problems, *, lists: bool
) -> list[tuple[str, Any]]:
    """Checked dotted overrides of ``table``; with ``lists``, each value is a list of values."""
    out: list[tuple[str, Any]] = []
    source = f"{problems.source}: {where}"
    for key, value in flatten(table).items():
        if key in RESERVED:
            problems.add(f"{source}: key '{key}' is set by the spec's `seeds`, not here")
            continue
        if not lists:
            converted = problems.checked(_converter(key, value, source))
            if converted is not None:
                out.append((key, converted))
            continue
        if not isinstance(value, list) or not value:
            problems.add(f"{source}: key '{key}': expected a non-empty list of values")
            continue
        values = [problems.checked(_converter(key, v, source)) for v in value]
        if all(v is not None for v in values):
            out.append((key, tuple(values)))
    return out


def _variants(value: Any, problems: _Problems) -> tuple[Variant, ...]:
    if value is None:
        return (Variant(DEFAULT_VARIANT),)
    if not isinstance(value, list) or not all(isinstance(v, Mapping) for v in value):
        problems.add(f"{problems.source}: field 'variants': expected tables ([[variants]])")
        return ()
    out: list[Variant] = []
    for i, table in enumerate(value):
        name = table.get("name")
        if not isinstance(name, str) or not name:
            problems.add(f"{problems.source}: field 'variants[{i}].name': expected a name")
            continue
        if name in (v.name for v in out):
            problems.add(f"{problems.source}: field 'variants[{i}].name': {name!r} twice")
        rest = {k: v for k, v in table.items() if k != "name"}
        out.append(
            Variant(name, tuple(_overrides(rest, f"variants.{name}", problems, lists=False)))
        )
    return tuple(out)


def parse_spec(data: Mapping[str, Any], source: Path) -> SweepSpec:
    """A sweep spec from its TOML mapping; one ConfigError listing every mistake."""
    problems = _Problems(source)
    here = source.parent
    for key in sorted(set(data) - set(TOP_KEYS)):
        problems.add(f"{source}: unknown field '{key}'; expected one of: {', '.join(TOP_KEYS)}")
    logs = _logs(data["logs"], here, problems) if "logs" in data else ()
    entries = data.get("simulate", [])
    if not isinstance(entries, list):
        problems.add(f"{source}: field 'simulate': expected tables ([[simulate]])")
        entries = []
    simulate = [_simulate(e, i, here, problems) for i, e in enumerate(entries)]
    if not data.get("logs") and not entries:
        problems.add(f"{source}: no inputs: give `logs = [...]` and/or [[simulate]] entries")
    seeds = _seeds(data.get("seeds", [0]), "seeds", problems)
    before = len(problems.lines)
    base = ReplayConfig()
    if "config" in data:
        if isinstance(data["config"], str):
            base = problems.checked(lambda: load_replay_config(here / data["config"])) or base
        else:
            problems.add(f"{source}: field 'config': expected the path of a replay config")
    grid_table = data.get("grid", {})
    if not isinstance(grid_table, Mapping):
        problems.add(f"{source}: field 'grid': expected a table of key = [values]")
        grid_table = {}
    grid = _overrides(grid_table, "grid", problems, lists=True)
    variants = _variants(data.get("variants"), problems)
    metrics = MetricsConfig()
    if "metrics" in data:
        table = data["metrics"]
        if isinstance(table, Mapping):
            got = problems.checked(
                lambda: from_mapping(MetricsConfig, table, source=str(source), prefix="metrics")
            )
            metrics = got or metrics
        else:
            problems.add(f"{source}: field 'metrics': expected a table of metrics thresholds")
    spec = SweepSpec(
        source=source,
        logs=logs,
        simulate=tuple(s for s in simulate if s is not None),
        seeds=seeds,
        grid=tuple(grid),
        variants=variants,
        base=base,
        metrics=metrics,
    )
    if len(problems.lines) == before:  # cross-field checks of every effective configuration
        problems.lines += _combination_problems(spec, str(source))
    if problems.lines:
        raise ConfigError("\n".join(dict.fromkeys(problems.lines)))
    return spec


def _combination_problems(spec: SweepSpec, source: str) -> list[str]:
    out = []
    for variant, point in itertools.product(spec.variants, spec.grid_points()):
        try:
            spec.config(variant, point, 0)
        except (ValueError, ConfigError) as exc:
            shown = ", ".join(f"{k} = {v!r}" for k, v in point) or "no grid key"
            out.append(f"{source}: variant {variant.name!r} with {shown}: {exc}")
    return out


def parse_seeds(text: str, *, source: str = "--seeds") -> tuple[int, ...]:
    """Engine seeds from a command line: ``N`` (0 … N−1, as the spec's count), ``A-B``
    (A … B), or a comma-separated list of seeds and ranges (``0,3,10-14``)."""
    text = text.strip()
    seeds: list[int] = []
    try:
        if text.isdigit():
            count = int(text)
            if count < 1:
                raise ValueError(text)
            return tuple(range(count))
        for part in text.split(","):
            first, dash, last = part.strip().partition("-")
            lo, hi = int(first), int(last) if dash else int(first)
            if lo < 0 or hi < lo:
                raise ValueError(part)
            seeds += range(lo, hi + 1)
    except ValueError:
        seeds = []
    if not seeds or len(set(seeds)) != len(seeds):
        msg = (
            f"{source}: expected N (seeds 0 … N−1), A-B, or a list such as 0,3,10-14 of "
            f"distinct seeds ≥ 0, got {text!r}"
        )
        raise ConfigError(msg, parameter="seeds")
    return tuple(seeds)


def with_overrides(
    spec: SweepSpec, *, seeds: tuple[int, ...] | None = None, config: Path | None = None
) -> SweepSpec:
    """``spec`` with its engine seeds and its base replay configuration replaced (one side
    of an A/B comparison: the same spec, each side's seeds or configuration)."""
    changes: dict[str, Any] = {}
    if seeds is not None:
        changes["seeds"] = tuple(seeds)
    if config is not None:
        changes["base"] = load_replay_config(Path(config))
    out = dataclasses.replace(spec, **changes)
    problems = _combination_problems(out, f"{spec.source} with --config {config}")
    if problems:
        raise ConfigError("\n".join(problems))
    return out


def load_spec(path: Path) -> SweepSpec:
    """Read and check SPEC.toml."""
    path = Path(path)
    return parse_spec(read_toml(path), path.resolve())
