"""``flylog sweep``: 8 cells on the process pool with 2 workers against the same 8 cells on
1 worker, in the same run (the target: at least 1.7× on 2 cores), and Ray's overhead per
cell against the pool's (a local Ray cluster of 2 CPUs, the same cells).

Each cell replays the 2 s corridor fixture log through the asynchronous engine (1000 flies,
7.4 M evaluations of virtual budget) and scores it: about 3 s of work on an idle core.
Every sweep's wall time includes starting its workers and their warm-up (one tiny closed
loop each), as a user's sweep does; every cell runs each time (``--force``). The one-worker
and pool sweeps run twice, interleaved in both orders, and the best of each is kept.
The load average (other processes on the machine) is given with the figures, and the cores
each sweep kept busy (its workers' CPU time over its wall time). Wall times need a quiet
machine; CPU times do not, so the figures also split each worker's CPU time into its cells
(``cell_cpu_s``, alone and in the pool: the pool slowing cells down would show here) and
its start (spawn, imports, numba's kernels, the warm-up), and give the speed-up those CPU
times predict: one worker's start + 8 cells over a pool worker's start + 4 cells. A fixed
start of a cell's length or more per worker is what holds 8 cells on 2 workers below 2×.
"""

from __future__ import annotations

import math
import os
import resource
import statistics
import time
from dataclasses import dataclass
from pathlib import Path

from flylog.sweep.executors import Backend
from flylog.sweep.runner import SweepOptions, run_sweep

LOG = Path(__file__).resolve().parents[2] / "fixtures" / "logs" / "corridor.mcap"
CELLS = 8
SPEC = f"""
logs = ["{LOG}"]
seeds = {CELLS}
[grid]
"engine.flies" = [1000]
"""


def _children_cpu() -> float:
    """CPU seconds of this process's ended children (the pool's workers, once shut down)."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


@dataclass(frozen=True)
class Measured:
    wall: float  # s, the whole sweep
    cores: float  # the workers' CPU time / wall time (NaN for Ray: not this process's children)
    cell_cpu: float  # s, mean CPU time of the worker process over a cell (``cell_cpu_s``)
    start_cpu: float  # s, per worker: its CPU time outside cells (start, imports, warm-up)
    parent: float  # the sweep's own process: CPU time / wall time

    def __lt__(self, other: Measured) -> bool:
        return self.wall < other.wall


def _sweep(out_dir: Path, name: str, options: SweepOptions) -> Measured:
    spec = out_dir / "bench_sweep.toml"
    spec.write_text(SPEC, encoding="utf-8")
    cpu0, own0, t0 = _children_cpu(), time.process_time(), time.perf_counter()
    result = run_sweep(spec, out_dir / f"bench_sweep_{name}", options)
    wall = time.perf_counter() - t0
    parent = (time.process_time() - own0) / wall
    failed = [r["error"] for r in result.rows if r["status"] != "ok"]
    if failed or result.ran != CELLS:
        msg = f"bench sweep {name}: {len(failed)} failed, {result.ran} run: {failed[:1]}"
        raise RuntimeError(msg)
    cells = [float(r["cell_cpu_s"]) for r in result.rows]
    if options.backend is not Backend.PROCESSES:
        return Measured(wall, math.nan, statistics.fmean(cells), math.nan, parent)
    children = _children_cpu() - cpu0
    workers = options.workers or 1
    start = (children - sum(cells)) / workers
    return Measured(wall, children / wall, statistics.fmean(cells), start, parent)


def expected_speed_up(one: Measured, pool: Measured, workers: int = 2) -> float:
    """One worker's sweep over the pool's, from CPU times: a worker's start, then its share
    of the cells one after the other (the cells split evenly, the parent idle)."""
    serial = one.start_cpu + CELLS * one.cell_cpu
    parallel = pool.start_cpu + math.ceil(CELLS / workers) * pool.cell_cpu
    return serial / parallel


def _load() -> str:
    one, five, _ = os.getloadavg()
    return f"load average {one:.1f} (1 min), {five:.1f} (5 min) on {os.cpu_count()} cores"


def run(out_dir: Path) -> list[dict]:
    load_before = _load()
    one, two = SweepOptions(workers=1, force=True), SweepOptions(workers=2, force=True)
    # interleaved, in both orders (one worker first, then the pool first), best of each: a
    # change of the machine's load during the run weighs on both alike
    times: dict[str, list[Measured]] = {"one_worker": [], "pool": []}
    for order in (("one_worker", "pool"), ("pool", "one_worker")):
        for name in order:
            times[name].append(_sweep(out_dir, name, one if name == "one_worker" else two))
    serial, pool = min(times["one_worker"]), min(times["pool"])
    ray = _sweep(out_dir, "ray", SweepOptions(Backend.RAY, workers=2, force=True))
    note = (
        f"best of {len(times['pool'])} each, interleaved; before: {load_before}; after: {_load()}"
    )
    rows = [
        {"name": "one worker, 8 cells", "value": serial.wall, "unit": "s", "note": note},
        {
            "name": "cores kept busy by one worker (its threads: engine, planner, reading)",
            "value": serial.cores,
            "unit": "cores",
        },
        {"name": "cores kept busy by the pool of 2", "value": pool.cores, "unit": "cores"},
        {
            "name": "process pool of 2, 8 cells",
            "value": pool.wall,
            "unit": "s",
            "ratio": serial.wall / pool.wall,
            "reference": "one worker (speed-up)",
        },
        {"name": "CPU time per cell, one worker", "value": serial.cell_cpu, "unit": "s"},
        {
            "name": "CPU time per cell, pool of 2",
            "value": pool.cell_cpu,
            "unit": "s",
            "ratio": pool.cell_cpu / serial.cell_cpu,
            "reference": "one worker",
        },
        {
            "name": "CPU time of a worker outside cells (start, imports, warm-up), pool of 2",
            "value": pool.start_cpu,
            "unit": "s",
            "ratio": pool.start_cpu / pool.cell_cpu,
            "reference": "a cell's CPU time",
        },
        {"name": "the sweep's own process busy, pool of 2", "value": pool.parent, "unit": "cores"},
        {
            "name": "speed-up expected from the CPU times (load-free)",
            "value": expected_speed_up(serial, pool),
            "unit": "x",
            "note": "worker start + its 4 cells, against one worker's start + 8 cells",
        },
        {
            "name": "Ray (local, 2 CPUs), 8 cells",
            "value": ray.wall,
            "unit": "s",
            "ratio": ray.wall / pool.wall,
            "reference": "process pool of 2",
        },
        {
            "name": "Ray's overhead per cell over the pool's",
            "value": (ray.wall - pool.wall) / CELLS,
            "unit": "s",
            "note": "cluster start included, spread over the cells",
        },
    ]
    return rows
