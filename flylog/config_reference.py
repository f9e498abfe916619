"""``docs/configuration.md``: every key of every file flylog reads, made from the code.

The replay configuration, scene files, metrics thresholds and compare tolerances are each
walked from the dataclass they are loaded into, table by table, with each key's type,
default, unit, range and help from its ``param`` metadata (:func:`flylog.config.param`). A
nested table's defaults are those of its parent's default. A new key appears on the next
``make docs``; a new kind of file needs one :class:`ConfigFile` in :func:`config_files`.
"""

from __future__ import annotations

import dataclasses
import enum
import re
import textwrap
import types
import typing
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from flylog.config import to_mapping


@dataclass(frozen=True)
class ConfigFile:
    """One kind of TOML file flylog reads, and the dataclass it is loaded into."""

    title: str
    read_by: str  # the commands and options that read it
    root: type
    about: str
    per_name: str = ""  # set: the file holds one table of ``root`` per name (e.g. a metric)


def config_files() -> tuple[ConfigFile, ...]:
    # Imported here, not at the top: importing this module stays cheap and circle-free.
    from flylog.metrics.compare import Tolerance
    from flylog.metrics.config import MetricsConfig
    from flylog.replay.config import ReplayConfig
    from flylog.scene.spec import SceneSpec

    return (
        ConfigFile(
            "Replay configuration",
            "`flylog replay --config FILE`, `flylog simulate --drive planner --config FILE`, "
            "`flylog experiment` (its defaults)",
            ReplayConfig,
            "The engine, the planner and the pipeline around them. Command-line options "
            "override the file; the effective configuration is stored in the run's metadata "
            "record `flylog.replay`.",
        ),
        ConfigFile(
            "Scene files",
            "`flylog simulate SCENE`",
            SceneSpec,
            "The world, the robot's sensors and how it drives. Lengths in metres, angles in "
            "degrees; x forward at the start, y left, z up. The scene file is attached to "
            "every log it makes (`scene.toml`).",
        ),
        ConfigFile(
            "Metrics thresholds",
            "`flylog metrics --config FILE`",
            MetricsConfig,
            "The thresholds of the definitions in [metrics.md](metrics.md).",
        ),
        ConfigFile(
            "Compare tolerances",
            "`flylog compare --tolerances FILE`",
            Tolerance,
            "One table per metric of the summary table; keys a table leaves out keep the "
            "metric's default below, and `-t NAME=VALUE[%]` overrides the file.",
            per_name="METRIC",
        ),
    )


# Dataclasses with `param` fields that no file sets: their fields are command-line options
# (each documented by the command's --help), so they are not in configuration.md.
OPTIONS_ONLY = (
    "flylog.experiments.common.ExperimentOptions",
    "flylog.io.writer.LogConfig",
    "flylog.ros2.config.BagOptions",  # replay's --topic, --pair-tolerance, --sonar-window
    "flylog.scene.generate.GenerateConfig",  # scene generate's --passage-width, --difficulty
)


def qualified_name(cls: type) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


@dataclass(frozen=True)
class Key:
    name: str
    type: str
    default: str
    unit: str
    range: str
    help: str


@dataclass(frozen=True)
class Table:
    """One TOML table of a file: its dotted name, how it appears and its plain keys."""

    path: str  # dotted, "" for the top level
    cls: type
    help: str
    form: str  # "table", "optional table" or "array of tables"
    keys: tuple[Key, ...]


def _unwrap_optional(tp: Any) -> tuple[Any, bool]:
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        return args[0], len(args) < len(typing.get_args(tp))
    return tp, False


def _array_item(tp: Any) -> Any:
    """The dataclass of a ``tuple[X, ...]`` field (an array of tables), else None."""
    args = typing.get_args(tp)
    if typing.get_origin(tp) is tuple and len(args) == 2 and args[1] is Ellipsis:
        return args[0] if dataclasses.is_dataclass(args[0]) else None
    return None


def type_text(tp: Any) -> str:
    """A field's type as a TOML user reads it."""
    tp, optional = _unwrap_optional(tp)
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if isinstance(tp, type) and issubclass(tp, enum.Enum):
        text = " | ".join(f'"{m.value}"' for m in tp)
    elif origin is tuple and len(args) == 2 and args[1] is Ellipsis:
        text = f"[{type_text(args[0])}, …]"
    elif origin is tuple:
        text = "[" + ", ".join(type_text(a) for a in args) + "]"
    elif isinstance(tp, type):
        text = tp.__name__
    else:
        text = str(tp)
    return f"{text} (optional)" if optional else text


def value_text(value: Any) -> str:
    """A default as it is written in TOML."""
    value = to_mapping(value)
    if value is None:
        return "unset"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, list):
        return "[" + ", ".join(value_text(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {value_text(v)}" for k, v in value.items()) + "}"
    return repr(value)


def _number(x: float) -> str:
    return repr(int(x)) if float(x).is_integer() and abs(x) < 1e15 else repr(x)


def range_text(meta: Mapping[str, Any]) -> str:
    lo, hi = meta.get("min"), meta.get("max")
    if lo is not None and hi is not None:
        return f"{_number(lo)} … {_number(hi)}"
    if lo is not None:
        return f"≥ {_number(lo)}"
    if hi is not None:
        return f"≤ {_number(hi)}"
    return ""


def _cell(text: str) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def _docstring(cls: type) -> str:
    doc = cls.__doc__ or ""
    if doc.startswith(f"{cls.__name__}("):  # the signature dataclasses writes when none is
        return ""
    return " ".join(doc.strip().split("\n\n")[0].split())


def walk_tables(
    cls: type, default: Any, *, path: str = "", help: str = "", form: str = "table"
) -> Iterator[Table]:
    """``cls``'s table and every table below it, depth first, with the defaults ``default``
    (an instance) holds; ``default`` None: the fields' own defaults."""
    hints = typing.get_type_hints(cls)
    keys: list[Key] = []
    below: list[tuple[type, Any, str, str, str]] = []
    for f in dataclasses.fields(cls):
        meta = f.metadata
        tp, optional = _unwrap_optional(hints[f.name])
        if default is not None:
            value = getattr(default, f.name)
        elif f.default is not dataclasses.MISSING:
            value = f.default
        else:
            value = dataclasses.MISSING
        sub = f"{path}.{f.name}" if path else f.name
        item = _array_item(tp)
        if dataclasses.is_dataclass(tp):
            nested = value if dataclasses.is_dataclass(value) else None
            kind = "optional table" if optional else "table"
            below.append((typing.cast(type, tp), nested, sub, meta.get("help", ""), kind))
            continue
        if item is not None:
            below.append((item, None, sub, meta.get("help", ""), "array of tables"))
            continue
        keys.append(
            Key(
                name=f.name,
                type=type_text(hints[f.name]),
                default="required" if value is dataclasses.MISSING else value_text(value),
                unit=meta.get("unit", ""),
                range=range_text(meta),
                help=meta.get("help", ""),
            )
        )
    yield Table(path, cls, help, form, tuple(keys))
    for sub_cls, nested, sub, sub_help, kind in below:
        yield from walk_tables(sub_cls, nested, path=sub, help=sub_help, form=kind)


def config_classes() -> set[str]:
    """Qualified names of every dataclass a config file is loaded into."""
    return {
        qualified_name(t.cls)
        for cf in config_files()
        for t in walk_tables(cf.root, None, form="table")
    }


def _keys_table(keys: Sequence[Key]) -> list[str]:
    lines = ["| key | type | default | unit | range | meaning |", "|---|---|---|---|---|---|"]
    lines += [
        f"| `{k.name}` | {_cell(k.type)} | `{_cell(k.default)}` | {_cell(k.unit)} | "
        f"{_cell(k.range)} | {_cell(k.help)} |"
        for k in keys
    ]
    return lines


def _heading(cf: ConfigFile, table: Table) -> str:
    path = ".".join(p for p in (cf.per_name, table.path) if p)
    if not path:
        return "Top level"
    return f"`[[{path}]]`" if table.form == "array of tables" else f"`[{path}]`"


def _file_section(cf: ConfigFile) -> list[str]:
    lines = [f"## {cf.title}", "", f"Read by {cf.read_by}. {cf.about}", ""]
    for table in walk_tables(cf.root, None):
        lines.append(f"### {_heading(cf, table)}")
        lines.append("")
        what = [s[:1].upper() + s[1:] for s in (table.help, _docstring(table.cls)) if s]
        form = {"table": "", "optional table": "An optional table. "}.get(
            table.form, "An array of tables, one per item. "
        )
        about = " ".join(s if s.endswith(".") else s + "." for s in what)
        lines.append(f"{form}{about} (`{qualified_name(table.cls)}`)".strip())
        lines.append("")
        if table.keys:
            lines += _keys_table(table.keys)
            lines.append("")
    if cf.per_name:
        lines += _default_tolerances()
    return lines


def _default_tolerances() -> list[str]:
    from flylog.metrics.compare import DEFAULT_TOLERANCES

    lines = [
        "### Default tolerances",
        "",
        "A metric is judged only if it has a tolerance (a wall-clock figure only with one "
        "given for it; in open loop the trajectory's figures never: they are the log's). The "
        "candidate regresses if its worsening exceeds max(absolute, relative × |base mean|) "
        "with confidence 1 − alpha ([metrics.md](metrics.md#comparing-runs)). The run's metrics' "
        "defaults are their seed-to-seed sd on the bundled scenes, rounded up; the "
        "trajectory's, their sd over the closed-loop experiment's seeds (RPE's not measured).",
        "",
        "| metric | direction | absolute | relative |",
        "|---|---|---|---|",
    ]
    lines += [
        f"| `{name}` | {t.direction.value} | {_number(t.absolute)} | {_number(t.relative)} |"
        for name, t in DEFAULT_TOLERANCES.items()
    ]
    return [*lines, ""]


HEADER = (
    "<!-- Made by `make docs` (python -m flylog.reference_docs) from the config dataclasses' "
    "param metadata: edit the code, not this file; tests/test_docs.py checks it is current. -->"
)


def configuration_md() -> str:
    lines = [
        HEADER,
        "",
        "# Configuration",
        "",
        "Every file flylog reads is TOML; every table is optional and every key has the "
        "default below, except where it says *required*. Unknown keys, wrong types and values "
        "out of range are errors naming the file, the key and what is expected.",
        "",
    ]
    lines += [f"- [{cf.title}](#{_anchor(cf.title)}): {cf.read_by}" for cf in config_files()]
    lines.append("")
    for cf in config_files():
        lines += _file_section(cf)
    return "\n".join(lines).rstrip() + "\n"


def _anchor(title: str) -> str:
    return re.sub(r"[^a-z0-9 -]", "", title.lower()).replace(" ", "-")


def _comment(text: str, width: int = 88) -> list[str]:
    return textwrap.wrap(
        " ".join(text.split()), width - 2, initial_indent="# ", subsequent_indent="# "
    ) or ["#"]


def _toml_value(value: Any) -> str | None:
    """A default written as TOML, None for an unset (optional) value, which TOML cannot
    spell."""
    if to_mapping(value) is None:
        return None
    return value_text(value)


def sample_toml(cf: ConfigFile) -> str:
    """An annotated file of the kind ``cf``: every key at its default, each with its meaning,
    unit and range in a comment above it. Optional tables and arrays of tables are written
    commented out, since writing them changes the configuration."""
    lines = [
        f"# {cf.title}, every key at its default: a file to start from. Made by `make docs`",
        "# from the code (tests/test_docs.py checks it is current); a key left out keeps its",
        "# default, so a real file holds only the keys it changes.",
        *_comment(f"Read by {cf.read_by}. {cf.about}".replace("`", "")),
    ]
    for table in walk_tables(cf.root, None):
        off = table.form != "table" or any(
            part.form != "table"
            for part in walk_tables(cf.root, None)
            if part.path and (table.path + ".").startswith(part.path + ".")
        )
        prefix = "# " if off else ""
        lines.append("")
        what = [s[:1].upper() + s[1:] for s in (table.help, _docstring(table.cls)) if s]
        if what:
            lines += _comment(" ".join(s if s.endswith(".") else s + "." for s in what))
        if table.path:
            bracket = "[[{}]]" if table.form == "array of tables" else "[{}]"
            lines.append(prefix + bracket.format(table.path))
        for key in table.keys:
            notes = "; ".join(s for s in (key.unit, key.range) if s)
            lines += _comment(f"{key.help} ({notes})" if notes else key.help)
            if key.default in ("unset", "required"):
                lines.append(f"# {key.name} = ({key.default}: {key.type})")
            else:
                lines.append(f"{prefix}{key.name} = {key.default}")
    return "\n".join(lines) + "\n"
