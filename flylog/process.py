"""Process-wide settings for the processes flylog owns: the ``flylog`` command's
(:mod:`flylog.cli.main`) and the worker processes of a sweep or an experiment
(:func:`flylog.sweep.warm.start_worker`), so that a cell's replay runs as ``flylog replay``
does. Nothing here runs on import: a program that uses flylog as a library keeps its own
allocator and GIL settings."""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import threading
import time
import warnings
from collections.abc import Callable
from typing import Any, TypeVar

T = TypeVar("T")
R = TypeVar("R")

# glibc's malloc.h parameter numbers (stable since glibc 2.0)
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
# Blocks up to this size come from the heap and are reused after free: above a log chunk's
# decompressed size (LogConfig.chunk_size, 4 MiB, plus records) and within what every
# 64-bit glibc accepts (HEAP_MAX_SIZE / 2).
MMAP_THRESHOLD = 32 * 1024 * 1024
# Free memory at the heap's top goes back to the system only beyond this (a few chunks).
TRIM_THRESHOLD = 128 * 1024 * 1024


def keep_large_blocks() -> bool:
    """Make glibc's malloc keep freed multi-megabyte blocks for reuse; whether it applied.

    Why: reading a log decompresses each chunk (~4.6 MB at 640×480) into a fresh buffer and
    copies images out of it. glibc serves such blocks with mmap and unmaps them at free (its
    dynamic threshold follows the largest block freed, and the heap's top is trimmed beyond
    twice that), so every chunk and image costs freshly zeroed pages: on the 60 s replay
    reference log, 420 000 page faults and 1.5 s of CPU in the reading thread; 5 000 faults
    with these thresholds. It is the effect of MALLOC_MMAP_THRESHOLD_/MALLOC_TRIM_THRESHOLD_,
    which users cannot be asked to set. A no-op off glibc/Linux (macOS, Windows, musl).
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt  # the process's own symbols, libc's among them
    except (OSError, AttributeError):  # not glibc (musl has no mallopt)
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    # each returns 1 on success; setting either turns glibc's dynamic threshold off
    applied = mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)
    return bool(applied and mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD))


# Seconds a Python thread may hold the GIL while another waits for it (CPython: 0.005).
GIL_SWITCH_INTERVAL = 0.0005


def hand_the_gil_back_sooner() -> None:
    """Let a thread waiting for the GIL have it after 0.5 ms instead of 5 ms.

    Why: replay's engine thread leaves the GIL for each generation's compiled call (~0.6 ms)
    and needs it back at once for the few Python lines between two calls; meanwhile the
    reading thread and the planner's worker run Python (decoding, encoding, writing), and
    one of them kept it for up to the whole 5 ms slice. On the 60 s reference replay the
    wall time fell 2 % (5.95 -> 5.83 s, same CPU time)."""
    sys.setswitchinterval(GIL_SWITCH_INTERVAL)


def own_process() -> None:
    """Both settings, for a process flylog owns."""
    keep_large_blocks()
    hand_the_gil_back_sooner()


def one_line_warnings() -> None:
    """Print warnings as one line, ``warning: TEXT``, instead of Python's
    ``FILE:LINE: CATEGORY: TEXT`` and the source line: a worker process's warnings reach the
    user's terminal as the command's own do."""

    def formatted(message: Any, category: Any, filename: Any, lineno: Any, line: Any = None) -> str:
        text = " ".join(str(message).split("\n"))
        return f"warning: {text}\n"

    warnings.formatwarning = formatted


# Linux's prctl option: the signal a process receives when its parent ends.
_PR_SET_PDEATHSIG = 1
# How often a worker without prctl (not Linux) checks that its parent lives, s.
PARENT_POLL_S = 1.0


def end_with_parent(parent: int) -> str:
    """Make this worker process end when its parent ``parent`` ends, SIGKILL included;
    how (``"prctl"`` or ``"watchdog"``).

    Linux: ``prctl(PR_SET_PDEATHSIG, SIGTERM)``: the kernel signals the worker the moment
    its parent ends, with no thread and no polling; the worker's SIGTERM handler
    (:func:`stop_on_signals`) removes its partial outputs and exits. The signal is tied
    to the parent *thread* that started the worker: a sweep's pool starts its workers from
    the main thread, which lives as long as the sweep. A parent that ended before the call
    is caught by comparing ``getppid``. Elsewhere, a daemon thread polls ``getppid`` every
    PARENT_POLL_S."""
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            if libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM, 0, 0, 0) == 0:
                if os.getppid() != parent:  # it ended before the call
                    os.kill(os.getpid(), signal.SIGTERM)
                return "prctl"
        except (OSError, AttributeError):
            pass

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        os.kill(os.getpid(), signal.SIGTERM)

    threading.Thread(target=watch, name="flylog-parent-watch", daemon=True).start()
    return "watchdog"


class WorkerStopped(BaseException):
    """A stop signal reached a worker in the middle of its work (a BaseException, as
    KeyboardInterrupt: every output's ``with`` block on the way up removes its ``.part``)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


# The signals that stop a worker: Ctrl-C, SIGTERM (its parent's death, `kill`, CI
# time-outs) and SIGHUP (a closed terminal); all three reach it with its process group.
WORKER_STOP_SIGNALS = tuple(
    getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)
)


class _Busy:
    """Whether this worker process is inside a call (process-wide, as signals are)."""

    calls = 0


def _ignored(signum: int, frame: object) -> None:
    """A second stop signal, during the clean-up of the first. A Python handler rather than
    SIG_IGN: a signal already pending when the handler became SIG_IGN makes Python raise
    "OSError: Signal N ignored due to race condition" wherever the worker then is."""


def _on_worker_signal(signum: int, frame: object) -> None:
    for s in WORKER_STOP_SIGNALS:  # a second signal must not interrupt the clean-up
        signal.signal(s, _ignored)
    if not _Busy.calls:
        os._exit(128 + signum)  # idle: nothing to clean up, no traceback
    raise WorkerStopped(signum)


def stop_on_signals() -> None:
    """In a worker process: SIGINT, SIGTERM and SIGHUP end it at once, after the call in
    progress (inside :func:`stoppable_call`) removed its partial outputs, and with no
    traceback (Python's default for SIGTERM and SIGHUP kills it without clean-up, and
    KeyboardInterrupt ends it with one)."""
    for s in WORKER_STOP_SIGNALS:
        signal.signal(s, _on_worker_signal)


def stoppable_call(fn: Callable[[T], R], item: T) -> R:
    """``fn(item)``; a stop signal during it unwinds it (outputs cleaned up), then ends the
    process with 128 + the signal's number."""
    _Busy.calls += 1
    try:
        return fn(item)
    except WorkerStopped as exc:
        os._exit(128 + exc.signum)
    except KeyboardInterrupt:  # SIGINT before the handler was set
        os._exit(128 + signal.SIGINT)
    finally:
        _Busy.calls -= 1
