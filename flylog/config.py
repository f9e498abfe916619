"""Typed, frozen dataclass configurations loaded from TOML mappings.

Every default is written once, in the dataclass, with :func:`param`. Loading checks
names, types and ranges and raises :class:`~flylog.errors.ConfigError` naming the
file, the dotted field and what is expected.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import tomllib
import types
import typing
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar

from flylog.errors import ConfigError
from flylog.io.inputs import open_input

T = TypeVar("T")


def param(
    default: Any,
    *,
    help: str,
    unit: str = "",
    min: float | None = None,
    max: float | None = None,
) -> Any:
    """A dataclass field with its documentation, unit and allowed range."""
    meta = {"help": help, "unit": unit, "min": min, "max": max}
    if isinstance(default, (list, dict, set)):
        msg = "mutable defaults are not allowed in configs; use a tuple"
        raise TypeError(msg)
    return dataclasses.field(default=default, metadata=meta)


def describe(cls: type, name: str) -> str:
    """'help (default D unit)' for a config field: what --help prints."""
    f = {f.name: f for f in dataclasses.fields(cls)}[name]
    unit = f" {f.metadata.get('unit')}" if f.metadata.get("unit") else ""
    return f"{f.metadata.get('help', '')} [default: {f.default}{unit}]"


def read_toml(path: Path) -> dict[str, Any]:
    """Parse a TOML file, turning every failure into a ConfigError naming the file."""
    try:
        with open_input(path, "the TOML file") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        msg = f"{path}: no such file"
        raise ConfigError(msg) from None
    except UnicodeDecodeError:
        msg = f"{path}: not a TOML file (not UTF-8 text)"
        raise ConfigError(msg) from None
    except tomllib.TOMLDecodeError as exc:
        msg = f"{path}: not valid TOML ({exc})"
        raise ConfigError(msg) from None
    except OSError as exc:  # a directory, no permission, an I/O error
        msg = f"{path}: cannot be read ({exc.strerror or exc})"
        raise ConfigError(msg) from None


def problems_message(source: str, problems: Sequence[str]) -> str:
    """One line for one problem or several: ``FILE: problem`` or ``FILE: N problems: a; b``."""
    if len(problems) == 1:
        return f"{source}: {problems[0]}"
    return f"{source}: {len(problems)} problems: " + "; ".join(problems)


def _expected(tp: Any) -> str:
    origin = typing.get_origin(tp)
    if tp is bool:
        return "true or false"
    if tp is int:
        return "an integer"
    if tp is float:
        return "a number"
    if tp is str:
        return "a string"
    if isinstance(tp, type) and issubclass(tp, enum.Enum):
        return "one of " + ", ".join(repr(m.value) for m in tp)
    if origin is tuple:
        args = typing.get_args(tp)
        if len(args) == 2 and args[1] is Ellipsis:
            return f"a list of {_expected(args[0])}"
        return f"a list of {len(args)} values"
    if dataclasses.is_dataclass(tp):
        return "a table"
    return str(tp)


class _Bad:
    """What a field that failed its check converts to (its problem is already noted)."""


_BAD = _Bad()


def _convert(tp: Any, value: Any, where: str, problems: list[str]) -> Any:
    """``value`` converted to ``tp``, or _BAD with the problem appended to ``problems``."""
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if value is None:
            return None
        return _convert(args[0], value, where, problems)

    def bad() -> _Bad:
        problems.append(f"field '{where}': expected {_expected(tp)}, got {value!r}")
        return _BAD

    if tp is bool:
        return value if isinstance(value, bool) else bad()
    if tp is int:
        return bad() if isinstance(value, bool) or not isinstance(value, int) else value
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return bad()
        if not math.isfinite(value):  # TOML has nan and inf
            problems.append(f"field '{where}': expected a finite number, got {value!r}")
            return _BAD
        return float(value)
    if tp is str:
        return value if isinstance(value, str) else bad()
    if isinstance(tp, type) and issubclass(tp, enum.Enum):
        try:
            return tp(value)
        except ValueError:
            return bad()
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            return bad()
        members = typing.get_args(tp)
        if len(members) == 2 and members[1] is Ellipsis:
            members = (members[0],) * len(value)
        elif len(value) != len(members):
            return bad()
        items = tuple(
            _convert(a, v, f"{where}[{i}]", problems)
            for i, (a, v) in enumerate(zip(members, value, strict=True))
        )
        return _BAD if any(v is _BAD for v in items) else items
    if dataclasses.is_dataclass(tp):
        if not isinstance(value, Mapping):
            return bad()
        return _build(tp, value, where, problems)  # type: ignore[arg-type]
    msg = f"config type {tp!r} at '{where}' is not supported"
    raise TypeError(msg)


def _out_of_range(f: dataclasses.Field[Any], converted: Any, value: Any, where: str) -> str | None:
    if not isinstance(converted, (int, float)) or isinstance(converted, bool):
        return None
    lo, hi = f.metadata.get("min"), f.metadata.get("max")
    unit = f" {f.metadata['unit']}" if f.metadata.get("unit") else ""
    if lo is not None and converted < lo:
        return f"field '{where}': must be at least {lo}{unit}, got {value!r}"
    if hi is not None and converted > hi:
        return f"field '{where}': must be at most {hi}{unit}, got {value!r}"
    return None


def _build(cls: type[T], data: Mapping[str, Any], prefix: str, problems: list[str]) -> Any:
    """``cls`` built from ``data``, or _BAD with every problem found appended."""
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    before = len(problems)
    dotted = f"{prefix}." if prefix else ""
    for name in sorted(set(data) - set(fields)):
        problems.append(
            f"unknown field '{dotted}{name}'; expected one of: {', '.join(sorted(fields))}"
        )
    kwargs: dict[str, Any] = {}
    for name, value in data.items():
        if name not in fields:
            continue
        where = f"{dotted}{name}"
        converted = _convert(hints[name], value, where, problems)
        if converted is _BAD:
            continue
        wrong = _out_of_range(fields[name], converted, value, where)
        if wrong is not None:
            problems.append(wrong)
            continue
        kwargs[name] = converted
    for n, f in fields.items():
        required = f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
        if required and n not in data:
            problems.append(f"missing field '{dotted}{n}' ({_expected(hints[n])})")
    if len(problems) > before:
        return _BAD
    try:
        return cls(**kwargs)
    except ConfigError as exc:  # cross-field checks in __post_init__
        problems.append(f"{prefix + ': ' if prefix else ''}{exc}")
        return _BAD


def from_mapping(cls: type[T], data: Mapping[str, Any], *, source: str, prefix: str = "") -> T:
    """Build the frozen dataclass ``cls`` from a TOML mapping, checking every field.

    Unknown keys, wrong types, numbers that are not finite and out-of-range values raise
    one ConfigError with the file (``source``) and, for every problem found, the dotted
    field name and what is expected.
    """
    problems: list[str] = []
    built = _build(cls, data, prefix, problems)
    if problems:
        raise ConfigError(problems_message(source, problems))
    return built  # type: ignore[no-any-return]


def to_mapping(obj: Any) -> Any:
    """A config as plain TOML/JSON-compatible values (enums by value, tuples as lists)."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: to_mapping(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, enum.Enum):
        return obj.value
    if isinstance(obj, (tuple, list)):
        return [to_mapping(v) for v in obj]
    return obj


def replace_dotted(obj: T, overrides: Mapping[str, Any], *, _prefix: str = "") -> T:
    """Return ``obj`` with ``{"engine.flies": 5000}``-style overrides applied (no None).

    Each value is checked as a file's would be (finite, inside the field's range):
    ConfigError naming the dotted field, with ``parameter`` the dotted name."""
    for dotted, value in overrides.items():
        if value is None:
            continue
        head, _, rest = dotted.partition(".")
        if rest:
            obj = dataclasses.replace(
                obj,  # type: ignore[type-var]
                **{
                    head: replace_dotted(
                        getattr(obj, head), {rest: value}, _prefix=f"{_prefix}{head}."
                    )
                },
            )
            continue
        where = _prefix + head
        field = {f.name: f for f in dataclasses.fields(obj)}[head]  # type: ignore[arg-type]
        if isinstance(value, float) and not math.isfinite(value):
            msg = f"'{where}' must be a finite number, got {value!r}"
            raise ConfigError(msg, parameter=where)
        wrong = _out_of_range(field, value, value, where)
        if wrong is not None:
            raise ConfigError(wrong.replace("field ", "", 1), parameter=where)
        obj = dataclasses.replace(obj, **{head: value})  # type: ignore[type-var]
    return obj
