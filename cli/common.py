"""What every command shares: turning library errors into messages and exit codes, progress."""

from __future__ import annotations

import functools
import sys
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

import click
from rich.console import Console

F = TypeVar("F", bound=Callable[..., Any])

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130

stderr = Console(stderr=True, highlight=False)
stdout = Console(highlight=False)


def reports_errors(fn: F) -> F:
    """Run a command body; a FlylogError becomes one red line on stderr and exit code 2,
    Ctrl-C exit code 130, and library warnings (e.g. a truncated log) yellow lines."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        from flylog.errors import FlylogError

        def show_warning(message, category, filename, lineno, file=None, line=None):
            stderr.print(f"[yellow]warning:[/] {message}", soft_wrap=True)

        previous = warnings.showwarning
        warnings.showwarning = show_warning
        try:
            return fn(*args, **kwargs)
        except FlylogError as exc:
            stderr.print(f"[red]error:[/] {exc}", soft_wrap=True)
            sys.exit(EXIT_BAD_INPUT)
        except KeyboardInterrupt:
            stderr.print("[red]interrupted[/]: no output was written")
            sys.exit(EXIT_INTERRUPTED)
        finally:
            warnings.showwarning = previous

    return wrapper  # type: ignore[return-value]


@contextmanager
def progress_bar(
    description: str, unit: str, console: Console = stderr
) -> Iterator[Callable[[float, float], None]]:
    """A rich progress bar with ETA on ``console``; yields ``update(done, total)`` in ``unit``
    (e.g. "frames", "s" of log time). Nothing when the console is not a terminal."""
    if not console.is_terminal:  # no bar: rich.progress is not even imported (~10 ms)
        yield lambda done, total: None
        return
    from flylog.cli.progress import drawn_progress_bar

    with drawn_progress_bar(description, unit, console) as update:
        yield update


def resolution(
    ctx: click.Context, param: click.Parameter, value: str | None
) -> tuple[int, int] | None:
    """Parse ``WxH`` (e.g. 320x240) for --resolution."""
    if value is None:
        return None
    try:
        w, h = (int(p) for p in value.lower().split("x"))
    except ValueError:
        msg = f"expected WIDTHxHEIGHT in pixels, e.g. 320x240, got {value!r}"
        raise click.BadParameter(msg) from None
    if w < 16 or h < 16:
        msg = f"images must be at least 16x16 pixels, got {value!r}"
        raise click.BadParameter(msg)
    return w, h


def principal_point(
    ctx: click.Context, param: click.Parameter, value: str | None
) -> tuple[float, float] | None:
    """Parse ``CX,CY`` (pixels) for --principal-point."""
    if value is None:
        return None
    try:
        cx, cy = (float(p) for p in value.split(","))
    except ValueError:
        msg = f"expected CX,CY in pixels, e.g. 319.5,239.5, got {value!r}"
        raise click.BadParameter(msg) from None
    return cx, cy


def human_bytes(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{n:.1f} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1024
    return f"{n:.1f} GiB"
