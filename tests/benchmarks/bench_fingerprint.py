"""The cost of a log's fingerprint (:mod:`flylog.io.fingerprint`) as a ratio of reading the
log: a 640×480 corridor log of SECONDS simulated (lz4, as `flylog simulate` writes it),
fingerprinted from its summary and by the streamed whole-file hash, against decoding all of
its messages with ``open_log(path).messages()``.
"""

from __future__ import annotations

import time
from pathlib import Path

from flylog.io import open_log
from flylog.io.fingerprint import _file_fingerprint, log_fingerprint
from flylog.io.writer import Compression, LogConfig
from flylog.scene import load_scene
from flylog.sim.run import SimulationOptions, simulate

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
SECONDS = 10.0
REPEATS = 5


def _best(work) -> float:
    times = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        work()
        times.append(time.perf_counter() - t0)
    return min(times)


def _file_hash(path: Path) -> None:
    with path.open("rb") as fh:
        _file_fingerprint(fh)


def run(out_dir: Path) -> list[dict]:
    path = out_dir / "bench_fingerprint.mcap"
    options = SimulationOptions(
        duration=SECONDS, seed=0, resolution=(640, 480), log=LogConfig(Compression.LZ4)
    )
    simulate(load_scene(FIXTURES / "corridor.toml"), path, options)
    size_mb = path.stat().st_size / 1e6
    t0 = time.perf_counter()
    messages = sum(1 for _ in open_log(path).messages())
    read = time.perf_counter() - t0
    summary = _best(lambda: log_fingerprint(path))
    streamed = _best(lambda: _file_hash(path))
    reference = f"reading its {messages} messages ({read:.2f} s)"
    note = f"{size_mb:.0f} MB, {SECONDS:g} s log"
    path.unlink()
    return [
        {
            "name": "fingerprint from the summary",
            "value": summary * 1e3,
            "unit": "ms",
            "reference": reference,
            "ratio": summary / read,
            "note": note,
        },
        {
            "name": "fingerprint by a streamed file hash",
            "value": streamed * 1e3,
            "unit": "ms",
            "reference": reference,
            "ratio": streamed / read,
            "note": note,
        },
    ]
