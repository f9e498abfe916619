"""The ``flylog`` entry point. Subcommands import their heavy modules lazily so that
``--help`` answers at once."""

from __future__ import annotations

import gc
import importlib
import os
import sys
from typing import NoReturn

import click

from flylog.process import own_process

# command name → (module in flylog.cli, function name)
_COMMANDS = {
    "calibrate": ("calibrate", "calibrate"),
    "simulate": ("simulate", "simulate"),
    "replay": ("replay", "replay"),
    "metrics": ("metrics", "metrics"),
    "compare": ("compare", "compare"),
    "export": ("export", "export"),
    "experiment": ("experiment", "experiment"),
    "sweep": ("sweep", "sweep"),
    "report": ("report", "report"),
    "import": ("import_", "import_"),
    "scene": ("scene", "scene"),
    "describe": ("describe", "describe"),
}


class _LazyGroup(click.Group):
    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(_COMMANDS)

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name not in _COMMANDS:
            return None
        module, attr = _COMMANDS[name]
        return getattr(importlib.import_module(f"flylog.cli.{module}"), attr)


@click.group(cls=_LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="flylog")
def cli() -> None:
    """flylog: simulate a stereo + sonar + odometry robot, replay its logs through the fly
    algorithm and a harmonic-function planner, and score the runs."""


def freeze_imported_objects() -> None:
    """Leave the objects made so far out of every later garbage collection (gc.freeze), for
    a command to call once its heavy imports are done.

    Why: the modules, classes and numba's type registries that the imports make (~120 000
    objects) live until the process exits, and each full collection walks them all:
    without the freeze, two during the 60 s reference replay, 70-90 ms of the main thread at
    its start (where nothing else runs); with it, one, 20-40 ms, after this (while numba
    loads its cache).
    Process-wide: here, not in the library. Collections come as often again as Python's
    defaults have them (main() makes them rarer while the command imports)."""
    gc.freeze()
    gc.set_threshold(*_GC_THRESHOLDS)


def exit_at_once(code: object) -> NoReturn:
    """End the process with ``code`` (as ``sys.exit`` reads it) without the interpreter's
    teardown, once stdout and stderr are flushed.

    Why: a command has closed (and made durable) its outputs when it returns, and what is
    left is freeing memory: the modules, numba's and LLVM's state, the arrays. After the 60
    s reference replay, from its summary line to the process's end: 96-124 ms with the
    teardown, 22-31 ms without (machine loaded by other jobs), on the command's critical
    path, where nothing else runs. atexit handlers do not run: flylog registers none, and
    every thread and file a command opens is closed by then."""
    if code is None:
        status = 0
    elif isinstance(code, int):
        status = code
    else:  # sys.exit("message"): printed, status 1
        print(code, file=sys.stderr)
        status = 1
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # closed or gone (a closed pipe): nothing to flush
            status = status or 1
    os._exit(status)


# Python's collection thresholds, and the youngest generation's while a command imports:
# the imports make ~120 000 objects that all live on, and every 700 of them set off a
# collection that had nothing to free. Main thread's collections in the 60 s reference
# replay command (gc.callbacks, machine loaded by other jobs): 0.13-0.19 s with the freeze
# alone, one of them full; 0.02-0.04 s with this too, none full.
_GC_THRESHOLDS = gc.get_threshold()
IMPORTS_GC_THRESHOLD = 200_000


def main() -> None:
    own_process()
    gc.set_threshold(IMPORTS_GC_THRESHOLD, *_GC_THRESHOLDS[1:])
    try:
        cli()
    except SystemExit as exc:  # click ends every command so (standalone mode)
        exit_at_once(exc.code)
    exit_at_once(0)
