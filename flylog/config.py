"""Typed, frozen dataclass configurations loaded from TOML mappings.

Every default is written once, in the dataclass, with :func:`param`. Loading checks
names, types and ranges and raises :class:`~flylog.errors.ConfigError` naming the
file, the dotted field and what is expected.
"""

from __future__ import annotations

import dataclasses
import enum
import tomllib
import types
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any, TypeVar

from flylog.errors import ConfigError

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
        with Path(path).open("rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        msg = f"{path}: no such file"
        raise ConfigError(msg) from None
    except tomllib.TOMLDecodeError as exc:
        msg = f"{path}: not valid TOML ({exc})"
        raise ConfigError(msg) from None


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


def _convert(tp: Any, value: Any, where: str, source: str) -> Any:
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if value is None:
            return None
        return _convert(args[0], value, where, source)
    bad = f"{source}: field '{where}': expected {_expected(tp)}, got {value!r}"
    if tp is bool:
        if not isinstance(value, bool):
            raise ConfigError(bad)
        return value
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(bad)
        return value
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(bad)
        return float(value)
    if tp is str:
        if not isinstance(value, str):
            raise ConfigError(bad)
        return value
    if isinstance(tp, type) and issubclass(tp, enum.Enum):
        try:
            return tp(value)
        except ValueError:
            raise ConfigError(bad) from None
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise ConfigError(bad)
        items = typing.get_args(tp)
        if len(items) == 2 and items[1] is Ellipsis:
            return tuple(
                _convert(items[0], v, f"{where}[{i}]", source) for i, v in enumerate(value)
            )
        if len(value) != len(items):
            raise ConfigError(bad)
        return tuple(
            _convert(a, v, f"{where}[{i}]", source)
            for i, (a, v) in enumerate(zip(items, value, strict=True))
        )
    if isinstance(tp, type) and dataclasses.is_dataclass(tp):
        if not isinstance(value, Mapping):
            raise ConfigError(bad)
        return from_mapping(tp, value, source=source, prefix=where)
    msg = f"config type {tp!r} at '{where}' is not supported"
    raise TypeError(msg)


def from_mapping(cls: type[T], data: Mapping[str, Any], *, source: str, prefix: str = "") -> T:
    """Build the frozen dataclass ``cls`` from a TOML mapping, checking every field.

    Unknown keys, wrong types and out-of-range values raise ConfigError with the
    file (``source``), the dotted field name and what is expected.
    """
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    unknown = sorted(set(data) - set(fields))
    if unknown:
        where = f"{prefix}." if prefix else ""
        msg = (
            f"{source}: unknown field '{where}{unknown[0]}'; "
            f"expected one of: {', '.join(sorted(fields))}"
        )
        raise ConfigError(msg)
    kwargs: dict[str, Any] = {}
    for name, value in data.items():
        where = f"{prefix}.{name}" if prefix else name
        f = fields[name]
        converted = _convert(hints[name], value, where, source)
        lo, hi = f.metadata.get("min"), f.metadata.get("max")
        unit = f" {f.metadata['unit']}" if f.metadata.get("unit") else ""
        if isinstance(converted, (int, float)) and not isinstance(converted, bool):
            if lo is not None and converted < lo:
                msg = f"{source}: field '{where}': must be at least {lo}{unit}, got {value!r}"
                raise ConfigError(msg)
            if hi is not None and converted > hi:
                msg = f"{source}: field '{where}': must be at most {hi}{unit}, got {value!r}"
                raise ConfigError(msg)
        kwargs[name] = converted
    missing = [
        n
        for n, f in fields.items()
        if n not in kwargs
        and f.default is dataclasses.MISSING
        and f.default_factory is dataclasses.MISSING
    ]
    if missing:
        where = f"{prefix}." if prefix else ""
        msg = f"{source}: missing field '{where}{missing[0]}' ({_expected(hints[missing[0]])})"
        raise ConfigError(msg)
    try:
        return cls(**kwargs)
    except (ValueError, TypeError) as exc:  # cross-field checks in __post_init__
        msg = f"{source}: {prefix + ': ' if prefix else ''}{exc}"
        raise ConfigError(msg) from None


def to_mapping(obj: Any) -> Any:
    """A config as plain TOML/JSON-compatible values (enums by value, tuples as lists)."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: to_mapping(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, enum.Enum):
        return obj.value
    if isinstance(obj, (tuple, list)):
        return [to_mapping(v) for v in obj]
    return obj


def replace_dotted(obj: T, overrides: Mapping[str, Any]) -> T:
    """Return ``obj`` with ``{"engine.flies": 5000}``-style overrides applied (no None)."""
    for dotted, value in overrides.items():
        if value is None:
            continue
        head, _, rest = dotted.partition(".")
        if rest:
            obj = dataclasses.replace(
                obj,  # type: ignore[type-var]
                **{head: replace_dotted(getattr(obj, head), {rest: value})},
            )
        else:
            obj = dataclasses.replace(obj, **{head: value})  # type: ignore[type-var]
    return obj
