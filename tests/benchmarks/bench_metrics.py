"""``flylog metrics`` against the replay: the target is under a tenth of the replay's own time.

A 10 s corridor log at 640×480 @ 15 Hz is simulated (with the ``flylog.trajectories``
record) and replayed here as bench_replay does (5000 flies, 10 generations per frame,
snapshots at 5 Hz); the figure is the metrics time over that replay's wall time (its
``flylog.replay`` metadata). Reference, in the same process, interleaved, best of
``REPEATS``: the plain way, the truth streamed from the topics (a copy
of the log without the record: every image chunk decompressed) and a per-pixel true view
(``truth_width`` = the image width). Also: a fresh ``flylog metrics`` process (imports and
numba's cache load included), the reference 60 s pair of bench_replay when bench-out holds
it, and how far the decimated figures lie from the per-pixel ones.

The true views: the metrics' numpy depth path (``flylog.sim.depth``, no numba to load)
against the simulator's compiled kernel on the same poses, in the same process, interleaved
(the kernel's load excluded: it is the start-up cost the numpy path exists to avoid; the
fresh-process import of the metrics path is timed apart, with whether numba came with it).

Command to command (the target's terms): a fresh ``flylog replay`` process on the log and a
fresh ``flylog metrics`` process on that replay's output, both timed here (process start
to exit), as a ratio; for the 10 s log and for bench_replay's 60 s reference log when
bench-out holds it (whose truth may come from its topics if the log predates the record).
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numba
import numpy as np

from flylog.geometry import Pose2D
from flylog.io import contract, open_log
from flylog.metrics.config import MetricsConfig
from flylog.metrics.result import run_facts
from flylog.metrics.score import score_run
from flylog.metrics.trajectory import PoseInterpolator
from flylog.metrics.view import TrueViews, block_rig
from flylog.replay.config import ReplayConfig
from flylog.replay.run import replay
from flylog.scene import load_scene
from flylog.sim.render import Renderer
from flylog.sim.run import SimulationOptions, simulate
from flylog.sources import read_truth
from tests.logcopy import copy_log

SCENES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
DURATION = 10.0
REPEATS = 3
METRICS_COMMANDS = 5
REPLAY_COMMANDS = 2
REPLAY = ReplayConfig(generations_per_frame=10)  # bench_replay's reference configuration
NEW = MetricsConfig()
OLD = MetricsConfig(truth_width=640)
COMPARED = ("precision", "recall", "f_score", "median_depth_error", "nearest_error_m")


def _without_record(source: Path, target: Path) -> Path:
    """A copy of a log without the trajectories record (its truth streams from the topics)."""
    return copy_log(
        source,
        target,
        metadata=lambda records: {
            name: values
            for name, values in records.items()
            if name != contract.TRAJECTORIES_METADATA
        },
        chunk_size=4 * 1024 * 1024,
    )


def _best(fn, repeats: int = REPEATS) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def _command_seconds(args: list[str], repeats: int) -> float:
    """Best wall time of a fresh ``flylog ARGS`` process (start to exit)."""
    flylog = Path(sys.executable).with_name("flylog")  # the installed command
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run([str(flylog), *args], check=True, capture_output=True)
        best = min(best, time.perf_counter() - t0)
    return best


def _commands(log: Path, run_file: Path, out: Path, label: str) -> dict:
    """``flylog metrics`` over ``flylog replay``, command to command, on the same run."""
    gens = str(REPLAY.generations_per_frame)
    replay_s = _command_seconds(
        ["replay", str(log), "-o", str(run_file), "--generations-per-frame", gens],
        REPLAY_COMMANDS,
    )
    metrics_s = _command_seconds(
        ["metrics", str(run_file), "--log", str(log), "-o", str(out)], METRICS_COMMANDS
    )
    source = read_truth(log).source.value
    return {
        "name": f"`flylog metrics` / `flylog replay` commands, {label}",
        "value": metrics_s,
        "unit": "s",
        "reference": f"replay command {replay_s:.2f} s",
        "ratio": metrics_s / replay_s,
        "note": f"best of {METRICS_COMMANDS} metrics and {REPLAY_COMMANDS} replay processes; "
        f"truth from the log's {source}; the target is a ratio < 0.1",
    }


def _views(log: Path, run_file: Path) -> dict:
    """The run's true views by the numpy depth path and by the renderer's kernel."""
    truth = read_truth(log)
    times = [m.log_time_ns for m in open_log(run_file).messages([contract.FLIES])]
    poses = PoseInterpolator(truth.true)(np.array(times))
    views = TrueViews(truth.scene, truth.rig, NEW.truth_width)
    kernel = Renderer(truth.scene, block_rig(truth.rig, views.block))
    kernel.render_depth(Pose2D(*poses[0]))  # its load is not what is compared here
    threads = numba.get_num_threads()
    numba.set_num_threads(1)  # as the metrics ran it: a small view gains nothing from threads
    numpy_s, kernel_s = [], []
    try:
        for _ in range(REPEATS + 2):  # interleaved, best of each
            numpy_s.append(_best(lambda: views.render(poses), 1)[0])
            kernel_s.append(_best(lambda: [kernel.render_depth(Pose2D(*p)) for p in poses], 1)[0])
        want = [kernel.render_depth(Pose2D(*p)) for p in poses]
    finally:
        numba.set_num_threads(threads)
    depth, ids = views.render(poses)
    equal = np.array_equal(depth, np.stack([d for d, _ in want])) and np.array_equal(
        ids, np.stack([i for _, i in want])
    )
    return {
        "name": f"true views, numpy depth path vs the compiled kernel ({len(poses)} views)",
        "value": min(numpy_s),
        "unit": "s",
        "reference": f"kernel {min(kernel_s):.3f} s (one thread, loaded)",
        "ratio": min(numpy_s) / min(kernel_s),
        "note": f"{depth.shape[2]}x{depth.shape[1]} blocks; equal bit for bit: {equal}",
    }


def _import_seconds() -> dict:
    """A fresh interpreter importing the metrics command's modules (best of 5)."""
    code = (
        "import sys, time; t = time.perf_counter()\n"
        "import flylog.cli.metrics, flylog.metrics.score\n"
        "print(time.perf_counter() - t, 'numba' in sys.modules)"
    )
    best, numba = float("inf"), ""
    for _ in range(5):
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        seconds, numba = out.stdout.split()
        best = min(best, float(seconds))
    return {
        "name": "fresh process: import of the metrics command's modules",
        "value": best,
        "unit": "s",
        "note": f"numba imported: {numba}",
    }


def _differences(new: dict, old: dict) -> str:
    return ", ".join(f"{k} {new[k] - old[k]:+.4f}" for k in COMPARED)


def run(out_dir: Path) -> list[dict]:
    log, run_file = out_dir / "metrics-log.mcap", out_dir / "metrics-run.mcap"
    simulate(load_scene(SCENES / "corridor.toml"), log, SimulationOptions(duration=DURATION))
    replay(log, run_file, REPLAY)
    replay_wall = run_facts(open_log(run_file), NEW).wall_seconds
    assert replay_wall is not None
    older = _without_record(log, out_dir / "metrics-log-older.mcap")

    new_times, old_times = [], []
    for _ in range(REPEATS):  # interleaved: the machine's load hits both alike
        new_t, new = _best(lambda: score_run(run_file, log, NEW), 1)
        old_t, old = _best(lambda: score_run(run_file, older, OLD), 1)
        new_times.append(new_t)
        old_times.append(old_t)
    new_t, old_t = min(new_times), min(old_times)
    snapshots = new.summary["snapshots"]
    truth_new, _ = _best(lambda: read_truth(log))
    truth_old, _ = _best(lambda: read_truth(older))
    older.unlink()  # a second copy of the log: no need to keep it
    command_run = out_dir / "metrics-run-command.mcap"
    commands = _commands(log, command_run, out_dir / "metrics-cli.parquet", f"{DURATION:g} s")
    figures = [
        commands,
        _views(log, run_file),
        _import_seconds(),
        {
            "name": f"flylog metrics / replay, corridor 640x480 {DURATION:g} s (in process)",
            "value": new_t,
            "unit": "s",
            "reference": f"replay wall {replay_wall:.2f} s",
            "ratio": new_t / replay_wall,
            "note": f"{snapshots} snapshots; the target is a ratio < 0.1",
        },
        {
            "name": "metrics with the truth streamed and a per-pixel view, same pair",
            "value": old_t,
            "unit": "s",
            "reference": "metrics (trajectories record, decimated view)",
            "ratio": old_t / new_t,
            "note": f"{old_t / replay_wall:.3f} of the replay's wall time",
        },
        {
            "name": "read truth: trajectories record vs streamed topics",
            "value": truth_new,
            "unit": "s",
            "reference": f"streamed {truth_old:.3f} s",
            "ratio": truth_old / truth_new,
            "note": f"{log.stat().st_size / 2**20:.0f} MiB log",
        },
        {
            "name": "decimated minus per-pixel figures (4x4 px blocks)",
            "value": abs(new.summary["precision"] - old.summary["precision"]),
            "unit": "|delta precision|",
            "note": _differences(new.summary, old.summary),
        },
    ]
    figures.extend(_reference_pair(out_dir))
    return figures


def _reference_pair(out_dir: Path) -> list[dict]:
    """bench_replay's 60 s pair, when it is there (its log may predate the record): in
    process on bench_replay's run, and command to command on a replay made here."""
    run_file = out_dir / "bench_replay_run.mcap"
    log = out_dir / "bench_replay_corridor_60s.mcap"
    if not (run_file.exists() and log.exists()):
        return []
    wall = run_facts(open_log(run_file), NEW).wall_seconds
    source = read_truth(log).source.value
    new_t, new = _best(lambda: score_run(run_file, log, NEW), 2)
    figures = [
        {
            "name": "flylog metrics / replay, bench_replay's 60 s pair (in process)",
            "value": new_t,
            "unit": "s",
            "reference": f"replay wall {wall:.2f} s" if wall else "replay wall unknown",
            "ratio": new_t / wall if wall else float("nan"),
            "note": f"{new.summary['snapshots']} snapshots; trajectories from the {source}",
        }
    ]
    command_run = out_dir / "metrics-run-60s-command.mcap"
    figures.append(_commands(log, command_run, out_dir / "metrics-cli-60s.parquet", "60 s"))
    return figures
