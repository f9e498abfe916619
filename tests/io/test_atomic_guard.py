"""The atomic writer's refusals: a registered input, a path inside an input directory, a
file that is not regular; temporary names within the file system's limit on a name."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from flylog.errors import OutputError
from flylog.io import atomic
from flylog.io.inputs import input_path, open_input, reading
from flylog.io.writer import LogWriter


def test_a_registered_input_is_never_replaced(tmp_path):
    source = tmp_path / "in.txt"
    source.write_text("input")
    os.symlink("in.txt", tmp_path / "soft.txt")
    os.link(source, tmp_path / "hard.txt")
    with reading():
        with open_input(source, "the input") as fh:
            fh.read()
        for name in ("in.txt", "soft.txt", "hard.txt", "sub/../in.txt"):
            (tmp_path / "sub").mkdir(exist_ok=True)
            with pytest.raises(OutputError, match="would overwrite the input") as info:
                atomic.write_text(tmp_path / name, "output")
            assert info.value.path == tmp_path / name
    assert source.read_text() == "input"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hard.txt", "in.txt", "soft.txt", "sub"]
    atomic.write_text(source, "outside a command: nothing is registered")


def test_nothing_is_written_inside_an_input_directory(tmp_path):
    bag = tmp_path / "bag"
    (bag / "deeper").mkdir(parents=True)
    with reading():
        input_path(bag, "the bag", directory=True)
        for target in (bag / "new.mcap", bag / "deeper" / "x"):
            with pytest.raises(OutputError, match="inside the bag"):
                atomic.write_bytes(target, b"x")
        atomic.write_bytes(tmp_path / "beside.mcap", b"x")  # beside it: fine
    assert sorted(p.name for p in bag.rglob("*")) == ["deeper"]


def test_a_log_writer_checks_again_when_it_publishes(tmp_path):
    """An input read after the temporary file was made (an import reads its images while
    writing) is refused at the rename, and the temporary file removed."""
    target = tmp_path / "im0.png"
    target.write_bytes(b"image")
    refused = pytest.raises(OutputError, match="would overwrite the image")
    with reading(), refused, LogWriter(target) as log:
        input_path(target, "the image")
        log.add_metadata("x", {"a": "b"})
    assert target.read_bytes() == b"image"
    assert [p.name for p in tmp_path.iterdir()] == ["im0.png"]


def test_a_fifo_is_refused_and_stays_a_fifo(tmp_path):
    fifo = tmp_path / "out.mcap"
    os.mkfifo(fifo)
    with pytest.raises(OutputError, match="is a FIFO"):
        atomic.write_bytes(fifo, b"x")
    with pytest.raises(OutputError, match="is a directory"):
        atomic.write_bytes(tmp_path, b"x")
    assert [p.name for p in tmp_path.iterdir()] == ["out.mcap"]


@pytest.mark.parametrize("length", [245, 255])
def test_a_long_legal_name_is_written_and_its_stale_parts_found(tmp_path, length):
    target = tmp_path / ("n" * (length - 5) + ".mcap")
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True).stdout.strip()  # fmt: skip
    fd, part = atomic.temporary_beside(target)
    os.close(fd)
    assert len(part.name.encode()) <= atomic.NAME_MAX
    stale = part.with_name(part.name.replace(f".{os.getpid()}-", f".{dead}-"))
    part.rename(stale)
    with LogWriter(target) as log:
        log.add_metadata("x", {"a": "b"})
    assert [p.name for p in tmp_path.iterdir()] == [target.name]  # the stale part removed


def test_a_batch_publishes_all_or_nothing(tmp_path):
    for name in ("a", "b"):
        (tmp_path / name).write_text("old")
    with pytest.raises(RuntimeError), atomic.Batch() as batch:
        for name in ("a", "b"):
            fd, tmp = atomic.temporary_beside(tmp_path / name)
            os.close(fd)
            atomic.publish(tmp, tmp_path / name, batch)
            if name == "b":
                raise RuntimeError
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a", "b"]
    assert (tmp_path / "a").read_text() == "old"
    with atomic.Batch() as batch:
        for name in ("a", "b"):
            fd, tmp = atomic.temporary_beside(tmp_path / name)
            os.write(fd, b"new")
            os.close(fd)
            atomic.publish(tmp, tmp_path / name, batch)
        assert (tmp_path / "a").read_text() == "old"  # not before the batch's end
    assert [(tmp_path / n).read_text() for n in ("a", "b")] == ["new", "new"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a", "b"]


def test_a_thread_reading_ahead_registers_with_its_command(tmp_path):
    from flylog.io.readahead import read_ahead

    source = tmp_path / "read-in-a-thread"
    source.write_text("x")

    def items():
        with open_input(source, "a file read ahead") as fh:
            yield fh.read()

    with reading() as inputs:
        assert list(read_ahead(items(), 2)) == [b"x"]
        assert [i.path for i in inputs] == [source]
    assert Path(source).read_text() == "x"
