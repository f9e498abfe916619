"""No command overwrites one of its inputs, or one output with another; outputs are atomic,
durable, take their mode from the umask and are found again after a killed writer."""

from __future__ import annotations

import errno
import os
import subprocess
import sys
from pathlib import Path

import pytest

from flylog.errors import OutputError
from flylog.io import atomic
from flylog.io.collisions import Role, check_outputs, same_file
from tests.reliability.conftest import error_lines, run


def test_same_file_sees_links_dots_and_absolute_paths(work):
    os.symlink("log.mcap", "soft.mcap")
    os.link("log.mcap", "hard.mcap")
    assert same_file("log.mcap", work / "log.mcap")
    assert same_file("log.mcap", "sub/../log.mcap")  # sub does not exist: resolved paths
    assert same_file("log.mcap", "soft.mcap")
    assert same_file("log.mcap", "hard.mcap")
    assert same_file("new.mcap", work / "new.mcap")  # neither exists
    assert not same_file("log.mcap", "s.toml")
    assert not same_file("log.mcap", "new.mcap")


def _prepare(work: Path) -> None:
    os.symlink("log.mcap", "soft.mcap")
    os.link("log.mcap", "hard.mcap")
    (work / "d").mkdir()
    (work / "d" / "true.tum").write_text("0 0 0 0 0 0 0 1\n")


COLLISIONS = [
    (["replay", "log.mcap", "-o", "{abs}/log.mcap"], "--output", "log.mcap"),
    (["replay", "log.mcap", "-o", "sub/../log.mcap"], "--output", "log.mcap"),
    (["replay", "log.mcap", "-o", "soft.mcap"], "--output", "log.mcap"),
    (["replay", "log.mcap", "-o", "hard.mcap"], "--output", "log.mcap"),
    (["replay", "log.mcap", "-o", "run.parquet"], "--output", None),  # run = step table
    (["replay", "log.mcap", "-o", "r.mcap", "--config", "r.parquet"], "--output", None),
    (["simulate", "s.toml", "-o", "s.toml"], "--output", "s.toml"),
    (["simulate", "s.toml", "-o", "{abs}/./s.toml"], "--output", "s.toml"),
    (
        ["simulate", "s.toml", "-o", "c.toml", "--drive", "planner", "--config", "c.toml"],
        "--output",
        None,
    ),
    (["metrics", "log.mcap", "-o", "m.summary.parquet"], "--output", None),
    (["metrics", "m.parquet", "--log", "log.mcap", "-o", "m.parquet"], "--output", None),
    (
        ["metrics", "log.mcap", "-o", "m.parquet", "--config", "m.obstacles.parquet"],
        "--output",
        None,
    ),
    (["export", "d/true.tum", "--tum", "d"], "--tum", "d/true.tum"),
]


@pytest.mark.parametrize(("args", "option", "kept"), COLLISIONS)
def test_an_output_colliding_with_an_input_or_output_is_refused(work, args, option, kept):
    _prepare(work)
    (work / "c.toml").write_text("seed = 1\n")
    args = [a.replace("{abs}", str(work)) for a in args]
    before = {p.name: p.read_bytes() for p in work.rglob("*") if p.is_file()}
    result = run(*args)
    assert result.exit_code == 2, result.output
    lines = error_lines(result)
    assert len(lines) == 1 and "same file" in lines[0], lines
    assert lines[0].endswith(f"choose another {option}")
    after = {p.name: p.read_bytes() for p in work.rglob("*") if p.is_file()}
    assert after == before  # nothing written, nothing changed
    if kept is not None:
        assert (work / kept).read_bytes() == before[Path(kept).name]


def test_check_outputs_names_the_output_parameter(tmp_path):
    log = tmp_path / "log.mcap"
    log.write_bytes(b"x")
    with pytest.raises(OutputError, match="would overwrite the log") as info:
        check_outputs([Role(log, "the log", "log")], [Role(tmp_path / "log.mcap", "a", "out")])
    assert info.value.parameter == "out"
    check_outputs([Role(log, "the log", "log")], [Role(tmp_path / "other", "a", "out")])


def test_an_output_inside_an_input_directory_is_refused(tmp_path):
    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    inputs = [Role(bag, "the sensor log", "log")]
    for out in (bag / "metadata.yaml", bag / "new.mcap", tmp_path / "x" / ".." / "bag" / "r"):
        with pytest.raises(OutputError, match="inside the sensor log") as info:
            check_outputs(inputs, [Role(out, "the run", "output")])
        assert info.value.parameter == "output"
    check_outputs(inputs, [Role(tmp_path / "bag.mcap", "the run", "output")])
    check_outputs(inputs, [Role(tmp_path / "bagx" / "r.mcap", "the run", "output")])


@pytest.mark.parametrize(
    "args",
    [
        ["simulate", "s.toml", "-o", "ro/x.mcap", "--duration", "0.2"],
        ["replay", "log.mcap", "-o", "ro/r.mcap"],
        ["metrics", "log.mcap", "-o", "ro/m.parquet"],
    ],
)
def test_a_read_only_output_directory_is_one_line_and_exit_2(work, monkeypatch, args):
    """As root a mode-0555 directory is writable, so the refusal of the file system is
    simulated (os.access, then os.open as a second line of defence)."""
    (work / "ro").mkdir()
    real_access = os.access
    monkeypatch.setattr(
        "flylog.io.collisions.os.access",
        lambda p, mode: False if Path(p).name == "ro" else real_access(p, mode),
    )
    result = run(*args)
    assert result.exit_code == 2, result.output
    lines = error_lines(result)
    assert len(lines) == 1 and "ro is not writable" in lines[0], lines
    assert list((work / "ro").iterdir()) == []


def test_the_writer_reports_a_directory_it_cannot_write(tmp_path, monkeypatch):
    def refuse(path, flags, mode=0o777):
        raise PermissionError(errno.EACCES, "Permission denied", str(path))

    monkeypatch.setattr(atomic.os, "open", refuse)
    with pytest.raises(OutputError, match=r"cannot write .*out.bin: directory .* is not writable"):
        atomic.write_bytes(tmp_path / "out.bin", b"data")


def test_experiment_in_a_read_only_directory_is_one_line_and_exit_2(work, monkeypatch):
    def refuse(self, *args, **kwargs):
        raise PermissionError(errno.EROFS, "Read-only file system", str(self))

    monkeypatch.setattr(Path, "mkdir", refuse)
    result = run("experiment", "proprioception", "-o", "ro", "--quick", "--duration", "0.2")
    assert result.exit_code == 2, result.output
    assert error_lines(result) == ["error: ro/proprioception/runs: Read-only file system"]


def test_outputs_take_the_umask_without_changing_it(tmp_path, monkeypatch):
    previous = os.umask(0o027)
    try:

        def forbidden(mask):
            raise AssertionError("the process-wide umask is read or changed")

        monkeypatch.setattr(atomic.os, "umask", forbidden)
        atomic.write_text(tmp_path / "a.txt", "hello")
        assert (tmp_path / "a.txt").stat().st_mode & 0o777 == 0o640
    finally:
        monkeypatch.undo()
        assert os.umask(previous) == 0o027


def test_the_file_is_made_durable_before_it_is_renamed(tmp_path, monkeypatch):
    calls: list[str] = []
    real_fsync, real_replace = os.fsync, os.replace
    monkeypatch.setattr(atomic.os, "fsync", lambda fd: (calls.append("fsync"), real_fsync(fd)))
    monkeypatch.setattr(
        atomic.os, "replace", lambda a, b: (calls.append("replace"), real_replace(a, b))
    )
    atomic.write_bytes(tmp_path / "b.bin", b"payload")
    assert calls[:2] == ["fsync", "replace"]
    assert (tmp_path / "b.bin").read_bytes() == b"payload"
    assert [p.name for p in tmp_path.iterdir()] == ["b.bin"]


def _dead_pid() -> int:
    child = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        capture_output=True,
        text=True,
        check=True,
    )
    return int(child.stdout)


def test_stale_parts_of_dead_writers_are_removed_and_live_ones_kept(tmp_path):
    target = tmp_path / "run.mcap"
    dead = tmp_path / f".run.mcap.{_dead_pid()}-0123abcd.part"
    live = tmp_path / f".run.mcap.{os.getpid()}-0123abcd.part"
    other = tmp_path / ".run.mcap.notapid.part"
    neighbour = tmp_path / f".run.mcap.x.{_dead_pid()}-0123abcd.part"  # another output's
    for p in (dead, live, other, neighbour):
        p.write_bytes(b"partial")
    atomic.write_bytes(target, b"whole")
    assert not dead.exists()
    assert live.exists() and other.exists() and neighbour.exists()
    assert target.read_bytes() == b"whole"


def test_export_tum_goes_through_the_atomic_writer(work):
    previous = os.umask(0o022)
    try:
        result = run("export", "log.mcap", "--tum", "tum")
    finally:
        os.umask(previous)
    assert result.exit_code == 0, result.output
    written = sorted(p.name for p in (work / "tum").iterdir())
    assert written == ["odom.tum", "true.tum"]  # no .part left
    for name in written:
        assert (work / "tum" / name).stat().st_mode & 0o777 == 0o644


def test_a_metrics_output_not_named_parquet_is_refused_before_scoring(work, monkeypatch):
    import flylog.metrics.score as score

    def never(*args, **kwargs):
        raise AssertionError("scored before the output's name was checked")

    monkeypatch.setattr(score, "score_run", never)
    result = run("metrics", "log.mcap", "-o", "m.csv")
    assert result.exit_code == 2
    (line,) = error_lines(result)
    assert "must end in .parquet" in line and line.endswith("choose another --output")
    assert sorted(p.name for p in work.iterdir()) == ["log.mcap", "s.toml"]
