"""Replay (issue 4): speed against the log's duration, peak memory, and the latency from an
obstacle entering the cameras' view to the planner's first reaction, async versus --sync.

Reference log: corridor, 640×480 @ 15 Hz, 60 s, six sonars, odometry at 50 Hz; replayed
with 5000 flies, 10 generations per frame, planner 200×200 at 10 Hz, all outputs written.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np

from flylog.config import replace_dotted
from flylog.experiments.reaction import first_visible_frames, reaction_delays
from flylog.replay.config import ReplayConfig
from flylog.replay.run import replay
from flylog.scene.load import load_scene
from flylog.sim.run import SimulationOptions, simulate

SCENES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
REFERENCE = ReplayConfig(generations_per_frame=10)
VISIBLE_PIXELS = 400  # an obstacle has entered the view when this many left pixels see it

_MEMORY_CHILD = """
import resource, sys
from pathlib import Path
from flylog.replay.config import ReplayConfig
from flylog.replay.run import replay
replay(Path(sys.argv[1]), Path(sys.argv[2]), ReplayConfig(generations_per_frame=10))
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
"""


def _log(out_dir: Path, scene: str, seconds: float) -> Path:
    path = out_dir / f"bench_replay_{scene}_{seconds:g}s.mcap"
    if not path.exists():
        simulate(load_scene(SCENES / f"{scene}.toml"), path, SimulationOptions(duration=seconds))
    return path


def _peak_rss_mb(log: Path, out: Path) -> float:
    done = subprocess.run(
        [sys.executable, "-c", _MEMORY_CHILD, str(log), str(out)],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    return int(done.stdout.split()[-1]) / 1024.0


def _speed(out_dir: Path) -> list[dict]:
    log = _log(out_dir, "corridor", 60.0)
    replay(_log(out_dir, "corridor", 1.0), out_dir / "bench_replay_warm.mcap", REFERENCE)
    summary = replay(log, out_dir / "bench_replay_run.mcap", REFERENCE)
    speed = summary.log_duration / summary.wall_seconds
    figures = [
        {
            "name": "replay corridor 640x480 60 s, 5000 flies, 10 gen/frame",
            "value": summary.wall_seconds,
            "unit": "s wall",
            "reference": "log duration",
            "ratio": speed,
            "note": f"{speed:.2f}x faster than real time; {summary.generations} generations "
            f"({summary.generations / summary.wall_seconds:.0f}/s), {summary.snapshots} "
            "snapshots, all outputs written",
        }
    ]
    long_log = _log(out_dir, "corridor", 120.0)
    for name, path in (("60 s", log), ("120 s", long_log)):
        figures.append(
            {
                "name": f"replay peak memory, {name} log",
                "value": _peak_rss_mb(path, out_dir / "bench_replay_mem.mcap"),
                "unit": "MB (max RSS)",
            }
        )
    return figures


def _latency(out_dir: Path) -> list[dict]:
    scene = load_scene(SCENES / "turn.toml")
    log = _log(out_dir, "turn", 8.0)
    rig = scene.spec.camera
    period = 1e9 / rig.frame_rate
    visible = first_visible_frames(log, scene, rig, VISIBLE_PIXELS)
    budget = REFERENCE.evals_per_second
    # Same compute budget for both: sync processes each complete frame with the generations
    # the budget affords in one frame period (paper Table 1: processing takes one cycle).
    per_frame = max(1, round(budget / rig.frame_rate / (REFERENCE.engine.flies / 2)))
    modes = {
        "async": replace_dotted(ReplayConfig(), {"snapshot_rate": rig.frame_rate}),
        "sync": replace_dotted(
            ReplayConfig(),
            {"sync": True, "generations_per_frame": per_frame, "snapshot_rate": rig.frame_rate},
        ),
    }
    figures = []
    for name, config in modes.items():
        run = out_dir / f"bench_replay_turn_{name}.mcap"
        replay(log, run, config)
        each = reaction_delays(run, scene, visible, period)
        delays = [d for d in each.values() if not math.isnan(d)]
        figures.append(
            {
                "name": f"obstacle entering view -> planner reaction, {name}",
                "value": float(np.median(delays)) if delays else math.nan,
                "unit": "frame periods (median)",
                "note": f"{len(delays)} of {len(visible)} obstacles that entered the view "
                f"reached the planner; each: {json.dumps([round(d, 1) for d in delays])}"
                + (f"; sync at {per_frame} generations/frame" if name == "sync" else ""),
            }
        )
    return figures


def run(out_dir: Path) -> list[dict]:
    return _speed(out_dir) + _latency(out_dir)
