"""Once per worker process: numba's thread count, and its compiled kernels loaded from the
on-disk cache (or compiled into it) by a tiny closed-loop run and a replay of its log, so
that no cell's wall time pays for them and two cells in one worker do not load them twice.
Both are needed: numba compiles a kernel once per argument types, and a replay's images,
read from the log, are read-only arrays where the closed loop's rendered ones are not."""

from __future__ import annotations

import functools
import gc
import tempfile
from pathlib import Path

# A closed loop of 0.2 s at 48x36 px through a scene with each kind of obstacle, then a
# replay of its log, both scored by the metrics: together they call every kernel a sweep's
# or an experiment's cell calls (renderer, sonar, engine, planner, truth; checked by
# tests/sweep/test_warm.py).
_WARM_SCENE = """
name = "warm-up"
duration = 0.2
[[obstacles]]
kind = "cylinder"
center = [1.0, -0.25]
radius = 0.1
height = 0.9
[[obstacles]]
kind = "box"
center = [2.0, 0.8]
size = [0.4, 0.4]
height = 1.0
[[obstacles]]
kind = "wall"
start = [3.0, -2.0]
end = [3.0, 2.0]
height = 1.2
[robot]
start = [0.0, 0.0, 0.0]
goal = [2.5, 0.0]
[drive]
commands = [{ t_start = 0.0, v = 0.1, w_deg = 0.0 }]
"""
_WARM_RESOLUTION = (48, 36)
# The same kernels as a cell's, at a fraction of the work (numba compiles per argument type,
# not per size or value): 64 flies, one generation a frame (on the virtual clock 64 flies
# would otherwise run ~23 000 generations in 0.2 s of log, 1.2 s of Python calls), and a
# planner grid of 8 m (80×80 cells instead of 200×200) whose warm start stops at 200 sweeps
# (with the default's 5000 the warm-up relaxes its two fields for 0.2 s).
_WARM_SETTINGS = {
    "engine.flies": 64,
    "generations_per_frame": 1,
    "planner.extent": 8.0,
    "planner.warm_start_sweeps": 200,
}


@functools.cache
def warm_up(numba_threads: int) -> float:
    """Set numba's threads for this process and run the tiny closed loop and replay (once per
    process and thread count); their wall time, s."""
    import time

    import numba

    from flylog.config import replace_dotted
    from flylog.metrics.config import MetricsConfig
    from flylog.metrics.score import score_run
    from flylog.replay.closed_loop import planner_driver
    from flylog.replay.config import ReplayConfig
    from flylog.replay.run import replay
    from flylog.scene.load import parse_scene
    from flylog.sim.run import SimulationOptions, simulate

    t0 = time.perf_counter()
    most = numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]
    numba.set_num_threads(max(1, min(numba_threads, most)))
    config = replace_dotted(ReplayConfig(), _WARM_SETTINGS)
    scene = parse_scene(_WARM_SCENE, source="warm-up scene")

    with tempfile.TemporaryDirectory(prefix="flylog-warm-") as tmp:
        log = Path(tmp) / "warm.mcap"
        options = SimulationOptions(resolution=_WARM_RESOLUTION)
        simulate(scene, log, options, make_driver=planner_driver(config))
        score_run(log, log, MetricsConfig())
        run = Path(tmp) / "replay.mcap"
        replay(log, run, config)
        score_run(run, log, MetricsConfig())
    return time.perf_counter() - t0


@functools.cache
def start_worker(numba_threads: int) -> float:
    """A worker process's start: the command's process settings
    (:func:`flylog.process.own_process`: glibc's allocator keeps the blocks a log's reading
    frees, 0.66× the reading thread's CPU on the 60 s reference log), :func:`warm_up`, then
    ``gc.freeze()``: the modules, kernels and objects loaded so far (~134 000 objects the
    collector tracks) live as long as the process, and frozen, the collections at the
    process's exit skip them: its exit takes 0.07 s instead of 0.37 s, which every sweep
    waits for once its last cell is done."""
    from flylog.process import own_process

    own_process()
    seconds = warm_up(numba_threads)
    gc.freeze()
    return seconds
