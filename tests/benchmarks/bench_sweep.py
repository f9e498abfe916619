"""``flylog sweep``: 8 cells on the process pool with 2 workers against the same 8 cells on
1 worker, in the same run (the target: at least 1.7× on 2 cores), and Ray's overhead per
cell against the pool's (a local Ray cluster of 2 CPUs, the same cells).

Each cell replays the 2 s corridor fixture log through the asynchronous engine (1000 flies,
7.4 M evaluations of virtual budget) and scores it: about 3 s of work on an idle core.
Every sweep's wall time includes starting its workers and their warm-up (one tiny closed
loop each), as a user's sweep does; every cell runs each time (``--force``). The one-worker
and pool sweeps run twice, interleaved in both orders, and the best of each is kept.
The load average (other processes on the machine) is given with the figures, and the cores
each sweep kept busy (its workers' CPU time over its wall time): a cell's replay runs the
engine, the planner and the log's reading in threads of their own, so one worker already
uses more than one core at times, and the pool's speed-up is bounded by 2 / that.
"""

from __future__ import annotations

import math
import os
import resource
import time
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


def _sweep(out_dir: Path, name: str, options: SweepOptions) -> tuple[float, float]:
    """(wall time, cores kept busy: the workers' CPU time / wall time; NaN for Ray, whose
    workers are not this process's children)."""
    spec = out_dir / "bench_sweep.toml"
    spec.write_text(SPEC, encoding="utf-8")
    cpu0, t0 = _children_cpu(), time.perf_counter()
    result = run_sweep(spec, out_dir / f"bench_sweep_{name}", options)
    wall = time.perf_counter() - t0
    cores = (_children_cpu() - cpu0) / wall if options.backend is Backend.PROCESSES else math.nan
    failed = [r["error"] for r in result.rows if r["status"] != "ok"]
    if failed or result.ran != CELLS:
        msg = f"bench sweep {name}: {len(failed)} failed, {result.ran} run: {failed[:1]}"
        raise RuntimeError(msg)
    return wall, cores


def _load() -> str:
    one, five, _ = os.getloadavg()
    return f"load average {one:.1f} (1 min), {five:.1f} (5 min) on {os.cpu_count()} cores"


def run(out_dir: Path) -> list[dict]:
    load_before = _load()
    one, two = SweepOptions(workers=1, force=True), SweepOptions(workers=2, force=True)
    # interleaved, in both orders (one worker first, then the pool first), best of each: a
    # change of the machine's load during the run weighs on both alike
    times: dict[str, list[tuple[float, float]]] = {"one_worker": [], "pool": []}
    for order in (("one_worker", "pool"), ("pool", "one_worker")):
        for name in order:
            times[name].append(_sweep(out_dir, name, one if name == "one_worker" else two))
    (serial, serial_cores), (pool, pool_cores) = min(times["one_worker"]), min(times["pool"])
    ray, _ = _sweep(out_dir, "ray", SweepOptions(Backend.RAY, workers=2, force=True))
    note = (
        f"best of {len(times['pool'])} each, interleaved; before: {load_before}; after: {_load()}"
    )
    return [
        {"name": "one worker, 8 cells", "value": serial, "unit": "s", "note": note},
        {
            "name": "cores kept busy by one worker (its threads: engine, planner, reading)",
            "value": serial_cores,
            "unit": "cores",
        },
        {"name": "cores kept busy by the pool of 2", "value": pool_cores, "unit": "cores"},
        {
            "name": "process pool of 2, 8 cells",
            "value": pool,
            "unit": "s",
            "ratio": serial / pool,
            "reference": "one worker (speed-up)",
        },
        {
            "name": "Ray (local, 2 CPUs), 8 cells",
            "value": ray,
            "unit": "s",
            "ratio": ray / pool,
            "reference": "process pool of 2",
        },
        {
            "name": "Ray's overhead per cell over the pool's",
            "value": (ray - pool) / CELLS,
            "unit": "s",
            "note": "cluster start included, spread over the cells",
        },
    ]
