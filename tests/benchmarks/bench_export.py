"""Export of a run: ROS 2 bag (run topics alone, and with its sensor log) and PLY snapshots,
speed as seconds of run per second of wall time and sizes per second of run; the sensor
log's own ROS 2 export in the same process is the same-run reference.

``FLYLOG_BENCH_RUN`` and ``FLYLOG_BENCH_LOG`` name a run and its log (docs/export.md: a
60 s corridor at 320x240); without them a 4 s corridor is simulated and replayed here."""

from __future__ import annotations

import os
import shutil
import time
from pathlib import Path

from flylog.fly import confidence
from flylog.fly.snapshot_export import export_ply
from flylog.io import open_log
from flylog.ros2.export import export_ros2
from flylog.ros2.run_export import export_run_ros2

SCENE = Path(__file__).resolve().parents[2] / "fixtures" / "scenes" / "corridor.toml"


def _inputs(out_dir: Path) -> tuple[Path, Path]:
    if os.environ.get("FLYLOG_BENCH_RUN"):
        return Path(os.environ["FLYLOG_BENCH_RUN"]), Path(os.environ["FLYLOG_BENCH_LOG"])
    from click.testing import CliRunner

    from flylog.cli.main import cli

    log, run = out_dir / "export_log.mcap", out_dir / "export_run.mcap"
    for path in (log, run):
        path.unlink(missing_ok=True)
    runner = CliRunner()
    sim = ["simulate", str(SCENE), "--duration", "4", "--resolution", "320x240", "-o", str(log)]
    assert runner.invoke(cli, sim).exit_code == 0
    assert runner.invoke(cli, ["replay", str(log), "-o", str(run)]).exit_code == 0
    return run, log


def _size(path: Path) -> int:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def run(out_dir: Path) -> list[dict]:
    run_path, log = _inputs(out_dir)
    reader = open_log(run_path)
    seconds = (reader.end_ns - reader.start_ns) / 1e9
    model = confidence.load()
    figures = []
    jobs = {
        "log to ROS 2 (reference)": lambda out: export_ros2(log, out),
        "run to ROS 2": lambda out: export_run_ros2(run_path, out, confidence=model),
        "run + log to ROS 2": lambda out: export_run_ros2(run_path, out, log=log, confidence=model),
        "run to PLY": lambda out: export_ply(run_path, out, confidence=model),
    }
    walls = {}
    for name, job in jobs.items():
        out = out_dir / ("export_" + name.split(" (")[0].replace(" ", "_").replace("+", "and"))
        shutil.rmtree(out, ignore_errors=True)
        t0, c0 = time.perf_counter(), time.process_time()
        job(out)
        walls[name] = time.perf_counter() - t0
        cpu = time.process_time() - c0
        size = _size(out)
        shutil.rmtree(out, ignore_errors=True)
        figures.append(
            {
                "name": f"{name}: speed",
                "value": seconds / walls[name],
                "unit": "x real time",
                "note": f"{seconds:.1f} s of run in {walls[name]:.2f} s",
            }
        )
        figures.append(
            {
                "name": f"{name}: speed on CPU time",
                "value": seconds / cpu,
                "unit": "x real time",
                "note": f"{cpu:.2f} s of the process's CPU (a loaded host's wall time waits)",
            }
        )
        figures.append({"name": f"{name}: size", "value": size / seconds / 1e6, "unit": "MB/s"})
    reference = walls["log to ROS 2 (reference)"]
    for fig in figures:
        name = fig["name"].split(": ")[0]
        if fig["unit"] == "x real time" and name in walls:
            fig["ratio"] = reference / walls[name]
            fig["reference"] = "log to ROS 2 wall time over this one's"
    return figures
