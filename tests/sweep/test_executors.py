from __future__ import annotations

import gc
import os
import sys

from flylog.process import GIL_SWITCH_INTERVAL
from flylog.sweep.executors import ProcessPool


def exit_on_one(x: int) -> int:
    """Kills its worker process for 1 (as the kernel's OOM killer or a crash would)."""
    if x == 1:
        os._exit(3)
    return 10 * x


def test_a_dead_worker_gives_lost_results_and_the_pool_starts_again() -> None:
    pool = ProcessPool(1, warm=False)
    try:
        lost = dict(pool.map_unordered(exit_on_one, [1], lost=lambda i, m: m))
        assert "a worker process ended abruptly" in lost[0]
        assert dict(pool.map_unordered(exit_on_one, [0, 2])) == {0: 0, 1: 20}
    finally:
        pool.close()


def worker_state(_: int) -> tuple[int, float]:
    return gc.get_freeze_count(), sys.getswitchinterval()


def test_a_warmed_worker_runs_as_the_command_does_its_start_left_out_of_collections() -> None:
    pool = ProcessPool(1)
    try:
        [(_, (frozen, switch))] = list(pool.map_unordered(worker_state, [0]))
    finally:
        pool.close()
    assert switch == GIL_SWITCH_INTERVAL  # flylog.process.own_process, as `flylog` sets it
    assert frozen > 50_000  # modules, numba's registries and kernels: ~134 000
