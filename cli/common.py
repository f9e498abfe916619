"""What every command shares: turning library errors into messages and exit codes, progress."""

from __future__ import annotations

import functools
import math
import os
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any, NoReturn, TypeVar

import click
from rich.console import Console
from rich.markup import escape

F = TypeVar("F", bound=Callable[..., Any])

EXIT_BAD_INPUT = 2
EXIT_BUG = 1
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as a shell reports Ctrl-C
# Signals handled as Ctrl-C is: what CI time-outs and `docker stop` send, and a closed terminal.
STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP) if hasattr(signal, "SIGHUP") else (signal.SIGTERM,)
DEBUG_VARIABLE = "FLYLOG_DEBUG"

stderr = Console(stderr=True, highlight=False)
stdout = Console(highlight=False)


class Terminated(BaseException):
    """A stop signal arrived (a BaseException, as KeyboardInterrupt: nothing catches it on
    the way up, and every output's ``with`` block removes its temporary file)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


# Stop signals received in the current command (process-wide, as signal handlers are). A
# handler's exception raised while a finaliser runs (a ``__del__`` or weakref callback, which
# garbage collection calls at any point) is printed and dropped by Python; the progress
# callbacks raise it again from here.
_received: list[int] = []


def _on_stop_signal(signum: int, frame: object) -> None:
    for s in STOP_SIGNALS:  # a second signal must not interrupt the clean-up
        signal.signal(s, signal.SIG_IGN)
    _received.append(signum)
    raise Terminated(signum)


def raise_if_stopped() -> None:
    """Raise Terminated if a stop signal arrived in this command, again if its first
    exception was dropped."""
    if _received:
        raise Terminated(_received[0])


def _unraisable_but_stops(previous: Callable[[Any], object]) -> Callable[[Any], None]:
    """An unraisable-exception hook that says nothing of a dropped Terminated (recorded in
    ``_received``, raised again at the next progress update) and passes the rest on: Python
    reports an exception it drops (in a finaliser, or in a ctypes callback such as numba's
    object cache notifying a compiled kernel) with a traceback on stderr, where the command
    prints one line."""

    def hook(unraisable: Any) -> None:
        if not isinstance(unraisable.exc_value, Terminated):
            previous(unraisable)

    return hook


@contextmanager
def stop_signals_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM and SIGHUP raise Terminated in the main thread."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _received.clear()
    previous = {s: signal.signal(s, _on_stop_signal) for s in STOP_SIGNALS}
    previous_hook = sys.unraisablehook
    sys.unraisablehook = _unraisable_but_stops(previous_hook)
    try:
        yield
    finally:
        sys.unraisablehook = previous_hook
        for s, handler in previous.items():
            signal.signal(s, handler)


def debugging() -> bool:
    """FLYLOG_DEBUG=1: errors show their traceback."""
    return os.environ.get(DEBUG_VARIABLE, "") not in ("", "0")


class OutputPath(click.Path):
    """click.Path for an option naming an output (a file or a folder written): an error of
    the atomic writer about a file names the option that sets it (``_output_parameter``)."""


def _output_parameter(ctx: click.Context, path: Any) -> str | None:
    """The output option (an OutputPath) whose value is ``path``, holds it (a folder), or
    names it with another suffix (run.mcap → run.parquet); the only one if none matches."""
    from flylog.io.collisions import same_file

    outputs = [
        (p.name, Path(ctx.params[p.name]))
        for p in ctx.command.params
        if isinstance(p.type, OutputPath) and p.name and ctx.params.get(p.name) is not None
    ]
    target = Path(os.fspath(path))
    for name, given in outputs:
        if same_file(given, target) or given in target.parents:
            return name
        if given.parent == target.parent and target.name.startswith(given.stem + "."):
            return name
    return outputs[0][0] if len(outputs) == 1 else None


def _option_hint(exc: Any) -> str:
    """'; choose another --output' for an error naming the parameter an option sets."""
    from flylog.errors import LimitError, OutputError

    name = getattr(exc, "parameter", None)
    ctx = click.get_current_context(silent=True)
    if ctx is None:
        return ""
    if name is None and isinstance(exc, OutputError) and exc.path is not None:
        name = _output_parameter(ctx, exc.path)
    if name is None:
        return ""
    for p in ctx.command.params:
        if p.name == name:
            flag = p.opts[-1] if isinstance(p, click.Option) else p.human_readable_name
            break
    else:
        return ""
    if isinstance(exc, OutputError):
        return f"; choose another {flag}"
    if isinstance(exc, LimitError):
        return f"; {flag} sets the limit"
    return f" (option {flag})"


def reports_errors(fn: F) -> F:
    """Run a command body and end it as a user expects.

    A FlylogError is one red line on stderr and exit code 2, as is an OSError (a file that
    cannot be read or written: the environment's, not flylog's); Ctrl-C exits with 130,
    SIGTERM and SIGHUP with 128 + the signal, each after removing the partial outputs; any
    other exception is a bug in flylog: one line saying so, exit code 1. FLYLOG_DEBUG=1
    adds the traceback. Library warnings (e.g. a truncated log) become yellow lines.

    The body runs with its own registry of inputs (flylog.io.inputs.reading): every file
    the command reads is registered, and the atomic writer refuses an output that would
    replace one, so no command can forget to declare its inputs."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        from flylog.errors import FlylogError
        from flylog.io.inputs import reading

        def show_warning(message, category, filename, lineno, file=None, line=None):
            stderr.print(f"[yellow]warning:[/] {message}", soft_wrap=True)

        previous = warnings.showwarning
        warnings.showwarning = show_warning
        try:
            with stop_signals_interrupt(), reading():
                return fn(*args, **kwargs)
        except (click.ClickException, click.exceptions.Exit, click.Abort):
            raise
        except FlylogError as exc:
            _error(f"{exc}{_option_hint(exc)}", EXIT_BAD_INPUT)
        except OSError as exc:
            where = f"{exc.filename}: " if exc.filename is not None else ""
            _error(f"{where}{exc.strerror or exc}", EXIT_BAD_INPUT)
        except KeyboardInterrupt:
            stderr.print("[red]interrupted[/]: no output was written")
            sys.exit(EXIT_INTERRUPTED)
        except Terminated as exc:
            name = signal.Signals(exc.signum).name
            stderr.print(f"[red]stopped by {name}[/]: no output was written")
            sys.exit(128 + exc.signum)
        except Exception as exc:
            if debugging():
                raise
            stderr.print(
                f"[red]internal error[/] (a bug in flylog, please report it): "
                f"{type(exc).__name__}: {exc}; {DEBUG_VARIABLE}=1 shows the traceback",
                soft_wrap=True,
            )
            sys.exit(EXIT_BUG)
        finally:
            warnings.showwarning = previous

    return wrapper  # type: ignore[return-value]


def _error(message: str, code: int) -> NoReturn:
    if debugging():
        stderr.print_exception()
    stderr.print(f"[red]error:[/] {escape(message)}", soft_wrap=True)
    sys.exit(code)


@contextmanager
def progress_bar(
    description: str, unit: str, console: Console = stderr, *, kernels: bool = False
) -> Iterator[Callable[[float, float], None]]:
    """A rich progress bar with ETA on ``console``; yields ``update(done, total)`` in ``unit``
    (e.g. "frames", "s" of log time). Nothing drawn when the console is not a terminal.
    Each update first raises a stop signal's exception that was dropped (raise_if_stopped).
    ``kernels``: the block calls numba kernels; their first compilation on this machine
    prints a line, and the bar counts them (flylog.cli.compiling)."""
    with ExitStack() as stack:
        if not console.is_terminal:  # no bar: rich.progress is not even imported (~10 ms)
            if kernels:
                from flylog.cli.compiling import compiles_shown

                stack.enter_context(compiles_shown(console))

            def checked(done: float, total: float) -> None:
                raise_if_stopped()

            yield checked
            return
        from flylog.cli.progress import drawn_progress_bar

        bar = stack.enter_context(drawn_progress_bar(description, unit, console))
        if kernels:
            from flylog.cli.compiling import compiles_shown

            stack.enter_context(compiles_shown(console, bar.note))

        def checked_update(done: float, total: float) -> None:
            raise_if_stopped()
            bar(done, total)

        yield checked_update


# Image sides the command line accepts: those of StereoRig's width and height.
MIN_IMAGE_SIDE, MAX_IMAGE_SIDE = 16, 8192


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
    if not (MIN_IMAGE_SIDE <= w <= MAX_IMAGE_SIDE and MIN_IMAGE_SIDE <= h <= MAX_IMAGE_SIDE):
        msg = f"image sides must be {MIN_IMAGE_SIDE} to {MAX_IMAGE_SIDE} pixels, got {value!r}"
        raise click.BadParameter(msg)
    return w, h


class Finite(click.FloatRange):
    """A finite number (NaN and ±inf refused) within an optional range."""

    name = "finite number"

    def _describe_range(self) -> str:
        """'finite' for an unbounded one (click would print ``x<=None``)."""
        if self.min is None and self.max is None:
            return "finite"
        return super()._describe_range()

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        number = click.FLOAT.convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        return super().convert(number, param, ctx)


def _finite_pair(value: str, names: str, unit: str, example: str) -> tuple[float, float]:
    """Two finite numbers ``A,B`` (``names`` such as "X,Y", in ``unit``), else BadParameter."""
    try:
        a, b = (float(p) for p in value.split(","))
    except ValueError:
        msg = f"expected {names} in {unit}, e.g. {example}, got {value!r}"
        raise click.BadParameter(msg) from None
    if not (math.isfinite(a) and math.isfinite(b)):
        msg = f"expected finite {names} in {unit}, got {value!r}"
        raise click.BadParameter(msg)
    return a, b


def point(ctx: click.Context, param: click.Parameter, value: str | None):
    """Parse ``X,Y`` in metres (finite numbers) for --goal."""
    return None if value is None else _finite_pair(value, "X,Y", "metres", "10,0.5")


SIZE_UNITS = {"": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}


class ByteSize(click.ParamType):
    """A size in bytes: 500M, 8G, 1.5T (binary units: K = 1024), or a plain number."""

    name = "size"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, int):
            return value
        text = str(value).strip().upper().removesuffix("IB").removesuffix("B")
        unit = text[-1:] if text[-1:] in SIZE_UNITS else ""
        try:
            number = float(text[: len(text) - len(unit)])
        except ValueError:
            number = math.nan
        if not (math.isfinite(number) and number > 0):
            self.fail(f"expected a size such as 500M, 8G or 1.5T, got {value!r}", param, ctx)
        return round(number * SIZE_UNITS[unit])


def limit_options(fn: F) -> F:
    """--max-output-size and --max-memory, the limits a job is checked against before it
    starts (flylog.budget)."""
    from flylog.budget import DEFAULT_LIMITS

    fn = click.option(
        "--max-memory",
        type=ByteSize(),
        default=DEFAULT_LIMITS.max_memory,
        metavar="SIZE",
        help="Refuse a job whose estimated peak memory is above SIZE (e.g. 16G). "
        f"[default: {human_bytes(DEFAULT_LIMITS.max_memory)}]",
    )(fn)
    fn = click.option(
        "--max-output-size",
        type=ByteSize(),
        default=DEFAULT_LIMITS.max_output_size,
        metavar="SIZE",
        help="Refuse a job whose estimated output is above SIZE (e.g. 100G). "
        f"[default: {human_bytes(DEFAULT_LIMITS.max_output_size)}]",
    )(fn)
    return fn


def principal_point(
    ctx: click.Context, param: click.Parameter, value: str | None
) -> tuple[float, float] | None:
    """Parse ``CX,CY`` (pixels) for --principal-point."""
    return None if value is None else _finite_pair(value, "CX,CY", "pixels", "319.5,239.5")


def human_bytes(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{n:.1f} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1024
    return f"{n:.1f} GiB"
