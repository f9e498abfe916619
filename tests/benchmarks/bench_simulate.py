"""The whole `flylog simulate` at 640×480: pairs/s, log size, and reading the log back.

The library call behind the command (:func:`flylog.sim.run.simulate`): render, sonar,
odometry, encoding and writing the MCAP log (compression, fsync and rename included), for
SECONDS of log on the corridor and clutter scenes, with lz4 (the default) and zstd chunks.
Reading: stereo pairs decoded per second when streaming that log with
``open_log(path).stereo_pairs()``.
"""

from __future__ import annotations

import time
from pathlib import Path

from flylog.io import open_log
from flylog.io.writer import Compression, LogConfig
from flylog.scene import load_scene
from flylog.sim.run import SimulationOptions, simulate

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
REAL_TIME_HZ = 15.0
SECONDS = 6.0
RESOLUTION = (640, 480)


def _options(compression: Compression, duration: float) -> SimulationOptions:
    return SimulationOptions(
        duration=duration,
        seed=0,
        resolution=RESOLUTION,
        frame_rate=REAL_TIME_HZ,
        log=LogConfig(compression=compression),
    )


def _read_rate(path: Path) -> tuple[float, int]:
    t0 = time.perf_counter()
    pairs = sum(1 for _ in open_log(path).stereo_pairs())
    return pairs / (time.perf_counter() - t0), pairs


def run(out_dir: Path) -> list[dict]:
    figures: list[dict] = []
    for name in ("corridor", "clutter"):
        scene = load_scene(FIXTURES / f"{name}.toml")
        # Warm-up: load (or compile) the numba kernels outside the timed runs.
        simulate(scene, out_dir / "bench_simulate_warmup.mcap", _options(Compression.LZ4, 0.2))
        (out_dir / "bench_simulate_warmup.mcap").unlink()
        for compression in (Compression.LZ4, Compression.ZSTD):
            path = out_dir / f"bench_simulate_{name}_{compression.value}.mcap"
            summary = simulate(scene, path, _options(compression, SECONDS))
            rate = summary.frames / summary.wall_seconds
            figures.append(
                {
                    "name": f"simulate {name} 640x480 {compression.value}",
                    "value": rate,
                    "unit": "stereo pairs/s",
                    "reference": f"{REAL_TIME_HZ:g} Hz real time",
                    "ratio": rate / REAL_TIME_HZ,
                    "note": f"{summary.frames} pairs, {summary.messages} messages, "
                    f"{1000 / rate:.1f} ms a pair, writing included",
                }
            )
            figures.append(
                {
                    "name": f"log size {name} 640x480 {compression.value}",
                    "value": summary.bytes / 1e6 * 60.0 / summary.duration,
                    "unit": "MB per minute",
                    "note": f"raw RGB stereo is {2 * 3 * 640 * 480 * 15 * 60 / 1e6:.0f} MB/min",
                }
            )
            read_rate, pairs = _read_rate(path)
            assert pairs == summary.frames, (pairs, summary.frames)
            figures.append(
                {
                    "name": f"read {name} {compression.value}",
                    "value": read_rate,
                    "unit": "decoded stereo pairs/s",
                    "note": "open_log(path).stereo_pairs() over the whole log",
                }
            )
            path.unlink()
    return figures
