"""Dotted configuration keys (``"engine.flies"``) checked against a config dataclass: the
field exists, and a value has its type and range, with the messages of
:func:`flylog.config.from_mapping`."""

from __future__ import annotations

import dataclasses
import typing
from collections.abc import Mapping
from typing import Any

from flylog.config import from_mapping
from flylog.errors import ConfigError


def leaf_field(cls: type, dotted: str) -> tuple[type, dataclasses.Field[Any]]:
    """(dataclass, field) that ``dotted`` names inside ``cls``; ConfigError if none."""
    parts = dotted.split(".")
    owner = cls
    for i, part in enumerate(parts):
        fields = {f.name: f for f in dataclasses.fields(owner)}  # type: ignore[arg-type]
        if part not in fields:
            where = ".".join(parts[:i]) or "the top level"
            msg = (
                f"unknown key '{dotted}': '{part}' is not a field of {where} "
                f"(expected one of: {', '.join(sorted(fields))})"
            )
            raise ConfigError(msg)
        if i == len(parts) - 1:
            return owner, fields[part]
        inner = typing.get_type_hints(owner)[part]
        if not dataclasses.is_dataclass(inner):
            msg = f"unknown key '{dotted}': '{'.'.join(parts[: i + 1])}' is not a table"
            raise ConfigError(msg)
        owner = inner  # type: ignore[assignment]
    msg = f"empty key {dotted!r}"
    raise ConfigError(msg)


def convert_value(cls: type, dotted: str, value: Any, *, source: str) -> Any:
    """``value`` converted to the type of the field ``dotted`` of ``cls`` (enums from their
    value, lists to tuples), its range checked; ConfigError naming ``source`` otherwise."""
    try:
        owner, field = leaf_field(cls, dotted)
    except ConfigError as exc:
        raise ConfigError(f"{source}: {exc}") from None
    if dataclasses.is_dataclass(typing.get_type_hints(owner)[field.name]):
        msg = f"{source}: key '{dotted}' is a table: name one of its fields"
        raise ConfigError(msg)
    prefix = dotted.rpartition(".")[0]
    built: Any = from_mapping(owner, {field.name: value}, source=source, prefix=prefix)
    return getattr(built, field.name)


def flatten(table: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"engine": {"flies": 1}, "planner.tick_rate": 2}`` → ``{"engine.flies": 1,
    "planner.tick_rate": 2}``: nested tables and dotted names alike."""
    out: dict[str, Any] = {}
    for key, value in table.items():
        dotted = f"{prefix}{key}"
        if isinstance(value, Mapping):
            out.update(flatten(value, f"{dotted}."))
        else:
            out[dotted] = value
    return out
