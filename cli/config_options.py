"""Command-line options generated from configuration fields.

A configuration field (:func:`flylog.config.param`) holds its help, unit, range and default;
:func:`config_option` makes the click option from them, so ``--help`` says what the
configuration file says and a range is checked once. The option's value is None unless
given, and :func:`config_overrides` collects the given ones as dotted overrides for
:func:`flylog.config.replace_dotted`, which checks them as a file's values are checked.
"""

from __future__ import annotations

import dataclasses
import enum
import importlib
import typing
from collections.abc import Callable
from typing import Any

import click

from flylog.cli.common import Finite

_FLAG_WORDS = {True: "on", False: "off"}


def config_field(cls: type, path: str) -> tuple[dataclasses.Field[Any], type]:
    """The dataclass field at the dotted ``path`` of ``cls``, and its resolved type."""
    head, _, rest = path.partition(".")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    hints = typing.get_type_hints(cls)
    if rest:
        return config_field(hints[head], rest)
    return fields[head], hints[head]


def _shown(value: Any) -> str:
    """A field's default as --help prints it: enums by value, booleans as on/off, and large
    round floats without an exponent (3.7e6 as 3700000)."""
    if isinstance(value, enum.Enum):
        return str(value.value)
    if isinstance(value, bool):
        return _FLAG_WORDS[value]
    if isinstance(value, float) and value.is_integer() and abs(value) >= 1e5:
        return str(int(value))
    return f"{value:g}" if isinstance(value, float) else str(value)


def _help(field: dataclasses.Field[Any]) -> str:
    text = str(field.metadata.get("help", ""))
    unit = field.metadata.get("unit") or ""
    default = _shown(field.default) + (f" {unit}" if unit else "")
    first = text.split(" ", 1)[0]
    if not first.endswith(":"):  # "flies: the fly algorithm" names a value: kept as written
        text = text[:1].upper() + text[1:]
    return f"{text}. [default: {default}]"


def _type(field: dataclasses.Field[Any], tp: type) -> click.ParamType | None:
    lo, hi = field.metadata.get("min"), field.metadata.get("max")
    if isinstance(tp, type) and issubclass(tp, enum.Enum):
        return click.Choice([str(e.value) for e in tp])
    if tp is bool:
        return None
    if tp is int:
        return click.IntRange(
            min=None if lo is None else int(lo), max=None if hi is None else int(hi)
        )
    if tp is float:
        return Finite(min=lo, max=hi)
    msg = f"no option type for a field of type {tp!r}"
    raise TypeError(msg)


def _resolve(spec: str) -> type:
    """The class at ``module:Name``."""
    module, _, name = spec.partition(":")
    return getattr(importlib.import_module(module), name)


class _FieldType(click.ParamType):
    """The field's type, resolved when first needed: importing a configuration pulls in the
    engine's kernels (numba, ~0.5 s), which a command that does not run should not pay."""

    def __init__(self, option: ConfigOption) -> None:
        self.option = option

    name = "value"

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str | None:
        kind = self.option.resolved()[1]
        return None if kind is None else kind.get_metavar(param, ctx)

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        kind = self.option.resolved()[1]
        return value if kind is None else kind.convert(value, param, ctx)


class ConfigOption(click.Option):
    """A click option that stands for the configuration field at ``config_path`` of the
    class ``config_class`` (``module:Name``), resolved on first use."""

    def __init__(self, *args: Any, config_class: str, config_path: str, **kwargs: Any) -> None:
        self.config_class = config_class
        self.config_path = config_path
        self._resolved: tuple[dataclasses.Field[Any], click.ParamType | None, type] | None = None
        if not kwargs.get("is_flag"):
            kwargs["type"] = _FieldType(self)
        super().__init__(*args, **kwargs)

    def resolved(self) -> tuple[dataclasses.Field[Any], click.ParamType | None, type]:
        if self._resolved is None:
            field, tp = config_field(_resolve(self.config_class), self.config_path)
            self._resolved = (field, _type(field, tp), tp)
        return self._resolved

    def get_help_record(self, ctx: click.Context) -> tuple[str, str] | None:
        field, kind, _ = self.resolved()
        self.help = _help(field)
        if isinstance(kind, click.types._NumberRangeBase):
            self.help += f"  [{kind._describe_range()}]"
        return super().get_help_record(ctx)


def config_option(
    config_class: str, path: str, *decls: str, metavar: str | None = None, flag: bool = False
) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """The option ``decls`` (e.g. ``"--flies"``) for the field ``path`` of the class
    ``config_class`` (``module:Name``); ``flag`` for a boolean field (click must know it
    before the class is imported; a test checks that it agrees)."""
    extra: dict[str, Any] = {"is_flag": True} if flag else {}
    return click.option(
        *decls,
        cls=ConfigOption,
        config_class=config_class,
        config_path=path,
        default=None,
        metavar=metavar,
        **extra,
    )


def config_overrides(ctx: click.Context | None = None) -> dict[str, Any]:
    """The given config options of the current command, as dotted overrides (enums made
    from their values; options not given are None, which replace_dotted skips)."""
    ctx = ctx or click.get_current_context()
    out: dict[str, Any] = {}
    for param in ctx.command.params:
        if isinstance(param, ConfigOption) and param.name is not None:
            value = ctx.params.get(param.name)
            tp = param.resolved()[2]
            if value is not None and isinstance(tp, type) and issubclass(tp, enum.Enum):
                value = tp(value)
            out[param.config_path] = value
    return out
