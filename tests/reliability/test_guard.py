"""Every command, each of its outputs aimed at each of its inputs: exit code 2, one line
naming the file and the option to change, and every file as it was.

The table lists every command of ``flylog``: a command added without its cases fails
:func:`test_every_command_has_its_cases`. What refuses is the atomic writer, which every
output goes through, checking the inputs the command registered as it read them
(:mod:`flylog.io.inputs`), not a list each command keeps."""

from __future__ import annotations

import os
import shutil
import stat
from pathlib import Path

import numpy as np
import pytest

from flylog.cli.main import _COMMANDS
from flylog.config import replace_dotted
from flylog.geometry import Pose2D, StereoRig
from flylog.metrics.score import score_run
from flylog.metrics.write import write_metrics
from flylog.replay.config import ReplayConfig
from flylog.replay.run import replay
from flylog.ros2.export import export_ros2
from flylog.sweep.results import results_columns, write_results
from tests.datasets.layouts import (
    plane_pair,
    write_euroc,
    write_kitti_sequence,
    write_kitti_stereo,
    write_middlebury_scene,
)
from tests.reliability.conftest import LOG, SCENE, error_lines, run

GRID = (("engine.flies", (200,)),)


def _results(path: Path, summary: dict, source: Path) -> None:
    """A sweep's results table of one cell (the columns the sweep writes, all of them)."""
    row = {c.name: None for c in results_columns(GRID)}
    row.update({k: v for k, v in summary.items() if k in row})
    row.update(cell=0, input="log.mcap", input_kind="log", seed=0, variant="default")
    row.update({"engine.flies": 200, "status": "ok", "run_dir": "cells/0", "fingerprint": "x"})
    path.parent.mkdir()
    write_results(path, GRID, [row], source)


@pytest.fixture(scope="module")
def artefacts(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A run of the turn log, its metrics, two sweeps' results, a bag and a dataset of each
    layout, made once."""
    out = tmp_path_factory.mktemp("artefacts")
    shutil.copy(LOG, out / "log.mcap")
    shutil.copy(SCENE, out / "s.toml")
    config = replace_dotted(ReplayConfig(), {"engine.flies": 100, "generations_per_frame": 1})
    replay(out / "log.mcap", out / "run.mcap", config)
    result = score_run(out / "run.mcap", out / "log.mcap")
    write_metrics(result, out / "m.parquet")
    write_metrics(result, out / "m2.parquet")
    (out / "c.toml").write_text("seed = 1\n")
    (out / "tol.toml").write_text('[precision]\ndirection = "higher"\nabsolute = 0.05\n')
    (out / "spec.toml").write_text('logs = ["log.mcap"]\nseeds = [0]\n')
    for name in ("sweep", "sweep2"):
        _results(out / name / "results.parquet", result.summary, out / "spec.toml")
    export_ros2(out / "log.mcap", out / "bag")
    write_middlebury_scene(out / "mb")
    rig = StereoRig(width=96, height=64, focal_px=120.0, baseline=0.16, frame_rate=10.0)
    left, right, disparity = plane_pair()
    d = np.where(np.isfinite(disparity), disparity, np.nan)
    write_kitti_stereo(out / "kitti", rig, [(left, right, d)])
    frames = [(k * 100_000_000, left, right) for k in range(2)]
    poses = [Pose2D(0.1 * k, 0.0, 0.0) for k in range(2)]
    write_kitti_sequence(out / "odo", rig, frames, poses)
    write_euroc(out / "euroc", rig, frames, [(f[0], p) for f, p in zip(frames, poses, strict=True)])
    return out


@pytest.fixture
def place(artefacts: Path, work: Path) -> Path:
    for item in artefacts.iterdir():
        target = work / item.name
        if item.is_dir():
            shutil.copytree(item, target)
        elif not target.exists():
            shutil.copy(item, target)
    return work


RUN_REPORT = ["report", "run.mcap", "--log", "log.mcap", "--metrics", "m.parquet", "-o"]
COMPARE = ["compare", "m.parquet", "m2.parquet", "--tolerances", "tol.toml", "--junit"]
SWEEPS = ["compare", "sweep/results.parquet", "sweep2/results.parquet", "--junit"]
MB, KT = "mb", "kitti/training"
SEQ, EUROC = "odo/sequences/00", "euroc/mav0"
EUROC_IMAGE = f"{EUROC}/cam0/data/0.png"

OUT = ("--output", "-o")
# command → (arguments, the output's option (its names), the input it is aimed at)
CASES: dict[str, list[tuple[list[str], str, str]]] = {
    "simulate": [
        (["simulate", "s.toml", "-o", "s.toml"], OUT, "s.toml"),
        (
            ["simulate", "s.toml", "--drive", "planner", "--config", "c.toml", "-o", "c.toml"],
            OUT,
            "c.toml",
        ),
    ],
    "replay": [
        (["replay", "log.mcap", "-o", "log.mcap"], OUT, "log.mcap"),
        (["replay", "log.mcap", "--config", "c.toml", "-o", "c.toml"], OUT, "c.toml"),
        (["replay", "bag", "-o", "bag/bag.mcap"], OUT, "bag/bag.mcap"),
        (["replay", "bag", "-o", "bag/new.mcap"], OUT, "bag"),
    ],
    "metrics": [
        (["metrics", "run.mcap", "--log", "log.mcap", "-o", "run.mcap"], OUT, "run.mcap"),
        (["metrics", "run.mcap", "--log", "log.mcap", "-o", "log.mcap"], OUT, "log.mcap"),
        (
            ["metrics", "run.mcap", "--log", "log.mcap", "--config", "c.toml", "-o", "c.toml"],
            OUT,
            "c.toml",
        ),
    ],
    "compare": [
        ([*COMPARE, "m.parquet"], ("--junit",), "m.parquet"),
        ([*COMPARE, "m2.summary.parquet"], ("--junit",), "m2.summary.parquet"),
        ([*COMPARE, "tol.toml"], ("--junit",), "tol.toml"),
        ([*SWEEPS, "sweep/results.parquet"], ("--junit",), "sweep/results.parquet"),
    ],
    "report": [
        ([*RUN_REPORT, "m.parquet"], OUT, "m.parquet"),
        ([*RUN_REPORT, "m.summary.parquet"], OUT, "m.summary.parquet"),
        ([*RUN_REPORT, "run.parquet"], OUT, "run.parquet"),
        ([*RUN_REPORT, "log.mcap"], OUT, "log.mcap"),
        (["report", "sweep", "-o", "sweep/results.parquet"], OUT, "sweep/results.parquet"),
    ],
    "export": [
        (["export", "log.mcap", "--ros2", "log.mcap"], ("--ros2",), "log.mcap"),
        (["export", "run.mcap", "--tum", "d"], ("--tum",), "d/true.tum"),
    ],
    "import": [
        *[
            (["import", "middlebury", MB, "-o", f"{MB}/{name}"], OUT, f"{MB}/{name}")
            for name in ("im0.png", "im1.png", "calib.txt", "disp0.pfm")
        ],
        *[
            (["import", "kitti", "kitti", "-o", f"{KT}/{name}"], OUT, f"{KT}/{name}")
            for name in (
                "image_2/000000_10.png",
                "image_3/000000_10.png",
                "calib_cam_to_cam/000000.txt",
                "disp_occ_0/000000_10.png",
            )
        ],
        *[
            (["import", "kitti", SEQ, "-o", name], OUT, name)
            for name in (
                f"{SEQ}/times.txt",
                f"{SEQ}/calib.txt",
                "odo/poses/00.txt",
                f"{SEQ}/image_3/000001.png",
            )
        ],
        *[
            (["import", "euroc", "euroc", "-o", name], OUT, name)
            for name in (
                f"{EUROC}/cam0/data.csv",
                f"{EUROC}/cam1/sensor.yaml",
                EUROC_IMAGE,
                f"{EUROC}/state_groundtruth_estimate0/data.csv",
            )
        ],
    ],
    "sweep": [
        (["sweep", "spec.toml", "-o", "spec.toml"], OUT, "spec.toml"),
        (["sweep", "spec.toml", "-o", "log.mcap"], OUT, "log.mcap"),
    ],
    # The experiments read flylog's own fixtures, never a path given on the command line:
    # an output folder that is one of them is refused as a file.
    "experiment": [
        (["experiment", "proprioception", "-o", "s.toml"], OUT, "s.toml"),
    ],
    "calibrate": [
        (["calibrate", "--fit", "run.mcap", "log.mcap", "-o", "run.mcap"], OUT, "run.mcap"),
        (["calibrate", "--fit", "run.mcap", "log.mcap", "-o", "log.mcap"], OUT, "log.mcap"),
    ],
    # describe prints a table's columns and writes nothing
    "describe": [],
    # scene generate reads nothing: its output aimed at what it cannot replace, a folder
    # for one world and a file for the folder of many
    "scene": [
        (["scene", "generate", "passages", "-o", "mb"], OUT, "mb"),
        (["scene", "generate", "clutter", "--seeds", "0-1", "-o", "s.toml"], OUT, "s.toml"),
    ],
}


def test_every_command_has_its_cases() -> None:
    assert set(CASES) == set(_COMMANDS)


def _snapshot(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in root.rglob("*") if p.is_file()}


@pytest.mark.parametrize(
    ("args", "option", "aimed"),
    [case for cases in CASES.values() for case in cases],
    ids=[" ".join(a[:1] + a[-1:]) for cases in CASES.values() for a, _, _ in cases],
)
def test_an_output_aimed_at_an_input_is_refused(place, args, option, aimed):
    if args[0] == "export" and "--tum" in args:
        (place / "d").mkdir()
        (place / "d" / "true.tum").write_text("0 0 0 0 0 0 0 1\n")
        args = ["export", "d/true.tum", "--tum", "d"]
    before = _snapshot(place)
    result = run(*args)
    assert result.exit_code == 2, result.output
    # one error line (click's usage errors come with two lines of usage before it)
    (line,) = [e for e in error_lines(result) if e.lower().startswith("error")]
    assert Path(aimed).name in line, line
    assert any(f"another {name}" in line or f"for '{name}'" in line for name in option), line
    assert _snapshot(place) == before  # nothing written, nothing changed


@pytest.mark.parametrize(
    "args",
    [
        ["simulate", "s.toml", "--duration", "1", "-o"],
        ["replay", "log.mcap", "-o"],
        ["report", "run.mcap", "--log", "log.mcap", "-o"],
        ["import", "middlebury", "mb", "-o"],
    ],
    ids=lambda a: a[0],
)
def test_a_fifo_output_is_refused_and_left_a_fifo(place, args):
    os.mkfifo(place / "out.fifo")
    result = run(*args, "out.fifo")
    assert result.exit_code == 2, result.output
    (line,) = error_lines(result)
    assert "out.fifo is a FIFO" in line and "choose another --output" in line
    assert stat.S_ISFIFO(os.stat(place / "out.fifo").st_mode)
    assert not [p for p in place.iterdir() if p.name.endswith(".part")]


def test_a_device_output_is_refused_before_any_file_is_made(place):
    result = run("simulate", "s.toml", "--duration", "1", "-o", "/dev/null")
    assert result.exit_code == 2, result.output
    (line,) = error_lines(result)
    assert "/dev/null is a character device" in line and "--output" in line
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


def test_an_interrupted_import_leaves_an_earlier_import_as_it_was(tmp_path):
    """A second import of many scenes over a finished one, stopped after two of its three
    logs: the three earlier logs are the same files with the same bytes, nothing else."""
    from flylog.datasets.run import import_dataset

    for k in range(3):
        write_middlebury_scene(tmp_path / "scenes" / f"s{k}", seed=k)
    out = tmp_path / "logs"
    import_dataset("middlebury", tmp_path / "scenes", out)
    found = {p.name: (p.stat().st_ino, p.read_bytes()) for p in out.iterdir()}
    assert len(found) == 3

    def stop(done: float, total: float) -> None:
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        import_dataset("middlebury", tmp_path / "scenes", out, limit=1, on_progress=stop)
    assert {p.name: (p.stat().st_ino, p.read_bytes()) for p in out.iterdir()} == found


def test_an_import_into_a_new_folder_stopped_leaves_no_folder(tmp_path):
    from flylog.datasets.run import import_dataset

    for k in range(2):
        write_middlebury_scene(tmp_path / "scenes" / f"s{k}", seed=k)

    def stop(done: float, total: float) -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        import_dataset("middlebury", tmp_path / "scenes", tmp_path / "new", on_progress=stop)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scenes"]


def test_a_245_character_output_name_is_written(place):
    name = "n" * 240 + ".mcap"
    result = run("import", "middlebury", "mb", "-o", name)
    assert result.exit_code == 0, result.output
    assert (place / name).stat().st_size > 0
    assert not [p for p in place.iterdir() if p.name.endswith(".part")]


@pytest.mark.parametrize(
    "args",
    [
        ["compare", "m.parquet", "m2.parquet"],  # a metrics output cut short
        ["compare", "sweep/results.parquet", "sweep2/results.parquet"],  # a sweep's results
    ],
    ids=["metrics", "sweep"],
)
def test_compare_of_a_cut_parquet_file_is_exit_2(place, args):
    cut = place / args[1]
    cut.write_bytes(cut.read_bytes()[:300])
    result = run(*args)
    assert result.exit_code == 2, result.output
    (line,) = error_lines(result)
    assert line.startswith(f"error: {args[1]}: not a readable Parquet file"), line


def test_a_replay_that_fails_closing_its_log_keeps_both_earlier_outputs(tmp_path, monkeypatch):
    """The run and its step table are published together: the log failing as it is
    finished (a full disk, say) leaves the earlier run and table as they were, not a new
    table beside the old run."""
    from mcap.writer import Writer

    for name in ("run.mcap", "run.parquet"):
        (tmp_path / name).write_bytes(b"earlier")

    def full(self):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Writer, "finish", full)
    config = replace_dotted(ReplayConfig(), {"engine.flies": 50, "generations_per_frame": 1})
    with pytest.raises(OSError, match="No space"):
        replay(LOG, tmp_path / "run.mcap", config)
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == {
        "run.mcap": b"earlier",
        "run.parquet": b"earlier",
    }


def test_a_245_character_bag_name_is_exported(tmp_path):
    name = "b" * 245
    export_ros2(LOG, tmp_path / name)
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]
