"""Process-wide settings for the processes flylog owns: the ``flylog`` command's
(:mod:`flylog.cli.main`) and the worker processes of a sweep or an experiment
(:func:`flylog.sweep.warm.start_worker`), so that a cell's replay runs as ``flylog replay``
does. Nothing here runs on import: a program that uses flylog as a library keeps its own
allocator and GIL settings."""

from __future__ import annotations

import ctypes
import sys

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
