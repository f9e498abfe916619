"""Chunk compression (none, lz4, zstd) of the three kinds of MCAP file flylog writes: sensor
logs, runs and ROS 2 exports. Size, write and read time, and the replay's wall time, in the
same process, the variants interleaved round after round (the figures to quote are the
ratios between variants of one round, and their medians over rounds).

- Logs: `simulate` of the corridor scene at 640×480, 15 Hz (the default camera), each
  compression; read back: every message decoded (``open_log(path).messages()``); replayed
  with the default configuration (the run uncompressed).
- Runs: the replay of the lz4 log written with each compression; read back by
  ``flylog metrics`` (its wall time).
- ROS 2 exports: the lz4 log exported (rgb8 images); its MCAP file copied record for record
  into lz4 and zstd chunks (mcap's writer, 4 MiB chunks), each read back with mcap's reader.
"""

from __future__ import annotations

import shutil
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

SECONDS = 6.0
ROUNDS = 2
COMPRESSIONS = ("none", "lz4", "zstd")


def _mib(path: Path) -> float:
    if path.is_dir():
        return sum(p.stat().st_size for p in path.rglob("*") if p.is_file()) / 2**20
    return path.stat().st_size / 2**20


def _timed(fn: Any, *args: Any, **kwargs: Any) -> float:
    t0 = time.perf_counter()
    fn(*args, **kwargs)
    return time.perf_counter() - t0


def _read_all(path: Path) -> None:
    from flylog.io import open_log

    for _ in open_log(path).messages():
        pass


def _recompress(source: Path, target: Path, compression: str) -> None:
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    kind = {"lz4": CompressionType.LZ4, "zstd": CompressionType.ZSTD}[compression]
    with source.open("rb") as fin, target.open("wb") as fout:
        reader = make_reader(fin)
        header = reader.get_header()
        writer = Writer(fout, compression=kind, chunk_size=4 * 2**20)
        writer.start(profile=header.profile, library=header.library)
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            if schema is not None and schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(
                    schema.name, schema.encoding, schema.data
                )
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic,
                    channel.message_encoding,
                    schemas.get(channel.schema_id, 0),
                    dict(channel.metadata),
                )
            writer.add_message(
                channels[channel.id],
                message.log_time,
                message.data,
                message.publish_time,
                message.sequence,
            )
        for record in reader.iter_metadata():
            writer.add_metadata(record.name, dict(record.metadata))
        writer.finish()


def _read_mcap(path: Path) -> None:
    from mcap.reader import make_reader

    with path.open("rb") as fh:
        for _ in make_reader(fh).iter_messages(log_time_order=False):
            pass


def run(out_dir: Path) -> list[dict[str, Any]]:
    import flylog.replay.run as replay_module
    from flylog.io.writer import Compression, LogConfig
    from flylog.metrics.score import score_run
    from flylog.replay.config import ReplayConfig
    from flylog.ros2.export import export_ros2
    from flylog.scene.bundled import resolve_scene
    from flylog.scene.load import load_scene
    from flylog.sim.run import SimulationOptions, simulate

    scene = load_scene(resolve_scene("corridor"))
    rows: dict[str, list[float]] = {}

    def note(name: str, value: float) -> None:
        rows.setdefault(name, []).append(value)

    with tempfile.TemporaryDirectory(prefix="flylog-bench-compression-") as tmp:
        here = Path(tmp)
        for r in range(ROUNDS):
            for c in COMPRESSIONS:
                log = here / f"log-{c}-{r}.mcap"
                options = SimulationOptions(
                    duration=SECONDS, seed=0, log=LogConfig(compression=Compression(c))
                )
                note(f"log {c}: simulate s", _timed(simulate, scene, log, options))
                note(f"log {c}: size MiB", _mib(log))
                note(f"log {c}: read s", _timed(_read_all, log))
                run_path = here / f"run-of-{c}-{r}.mcap"
                replay_module.RUN_COMPRESSION = Compression.NONE
                note(
                    f"log {c}: replay s",
                    _timed(replay_module.replay, log, run_path, ReplayConfig()),
                )
            log = here / f"log-lz4-{r}.mcap"
            for c in COMPRESSIONS:
                run_path = here / f"run-{c}-{r}.mcap"
                replay_module.RUN_COMPRESSION = Compression(c)
                note(
                    f"run {c}: replay s",
                    _timed(replay_module.replay, log, run_path, ReplayConfig()),
                )
                note(f"run {c}: size MiB", _mib(run_path))
                note(f"run {c}: metrics s", _timed(score_run, run_path, log))
            bag = here / f"bag-{r}"
            note("ros2 as exported: export s", _timed(export_ros2, log, bag))
            (mcap_file,) = bag.glob("*.mcap")
            note("ros2 as exported: size MiB", _mib(mcap_file))
            note("ros2 as exported: read s", _timed(_read_mcap, mcap_file))
            for c in ("lz4", "zstd"):
                copy = here / f"bag-{c}-{r}.mcap"
                note(f"ros2 {c} copy: write s", _timed(_recompress, mcap_file, copy, c))
                note(f"ros2 {c} copy: size MiB", _mib(copy))
                note(f"ros2 {c} copy: read s", _timed(_read_mcap, copy))
            shutil.rmtree(bag)
            for p in here.glob(f"*-{r}.*"):
                p.unlink()
    replay_module.RUN_COMPRESSION = Compression.NONE
    figures = []
    for name, values in rows.items():
        unit = name.rsplit(" ", 1)[1]
        figures.append(
            {
                "name": name,
                "value": statistics.median(values),
                "unit": unit,
                "note": "rounds: " + ", ".join(f"{v:.3g}" for v in values),
            }
        )
    return figures
