"""Sweeps under stress: spec mistakes and impossible sizes refused before anything is
written, one sweep per directory, and signals: SIGTERM to the sweep, SIGINT, SIGTERM and
SIGHUP to its process group, SIGKILL of the parent. Every case leaves no ``.part`` file, no
worker and no traceback behind."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from flylog.cli.main import cli
from flylog.sweep.limits import SweepLimits, cell_count, check_sweep
from flylog.sweep.lock import sweep_lock
from flylog.sweep.spec import load_spec

from .conftest import NEAR, write_spec

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "fixtures" / "scenes" / "near-obstacle.toml"
# Polling for a sweep to reach a state (its workers import numba and warm up first).
WAIT_S = 120.0

TINY = """
logs = ["{log}"]
seeds = {seeds}
[[variants]]
name = "per-frame"
generations_per_frame = 1
snapshot_rate = 15.0
"engine.flies" = 96
"""


def _sweep(*args: str):
    return CliRunner().invoke(cli, ["sweep", *args])


@pytest.mark.parametrize(
    ("text", "says"),
    [
        (TINY.format(log=NEAR, seeds="[18446744073709551616]"), "field 'seeds'"),
        (TINY.format(log=NEAR, seeds="[-1]"), "field 'seeds'"),
        ("logs = []\n", "no inputs"),
        (
            f'[[simulate]]\nscene = "{SCENE}"\nduration = 1e9\n',
            "field 'simulate[0]': a 1e+09 s simulation would write",
        ),
    ],
    ids=["seed above uint64", "negative seed", "no logs", "huge duration"],
)
def test_spec_mistakes_exit_2_and_leave_no_folder(tmp_path, text, says):
    spec = write_spec(tmp_path, text)
    out = tmp_path / "out"
    result = _sweep(str(spec), "-o", str(out))
    assert result.exit_code == 2, result.output
    assert says in result.stderr
    assert not out.exists()


def test_a_backend_that_cannot_run_is_refused_before_any_folder(tmp_path, monkeypatch):
    import importlib.util

    spec = write_spec(tmp_path, TINY.format(log=NEAR, seeds="[0]"))
    out = tmp_path / "out"
    result = _sweep(str(spec), "-o", str(out), "--address", "ray://head:10001")
    assert result.exit_code == 2 and "--backend ray" in result.stderr
    found = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "ray" else found(name, *a)
    )
    result = _sweep(str(spec), "-o", str(out), "--backend", "ray")
    assert result.exit_code == 2 and "needs Ray" in result.stderr
    assert not out.exists()


def test_the_cell_count_and_output_are_bounded_before_planning(tmp_path):
    grid = '[grid]\n"engine.flies" = [' + ", ".join(str(96 + k) for k in range(10)) + "]\n"
    spec = write_spec(tmp_path, TINY.format(log=NEAR, seeds="100000") + grid)
    out = tmp_path / "out"
    result = _sweep(str(spec), "-o", str(out))
    assert result.exit_code == 2
    assert "1000000 cells, over the limit of 10000; --max-cells sets the limit" in result.stderr
    assert not out.exists()
    loaded = load_spec(spec)
    assert cell_count(loaded) == 1_000_000
    with pytest.raises(Exception, match="would write about"):
        check_sweep(loaded, SweepLimits(max_cells=10**6, max_output_size=2**30))
    check_sweep(loaded, SweepLimits(max_cells=10**6, max_output_size=2**50))  # lifted
    small = write_spec(tmp_path, TINY.format(log=NEAR, seeds="[0]"), "small.toml")
    result = _sweep(str(small), "-o", str(out), "--max-output-size", "1K")
    assert result.exit_code == 2 and "--max-output-size sets the limit" in result.stderr


def test_a_second_sweep_into_the_same_folder_names_the_first(tmp_path):
    spec = write_spec(tmp_path, TINY.format(log=NEAR, seeds="[0]"))
    out = tmp_path / "out"
    out.mkdir()
    with sweep_lock(out):  # as a sweep running in this process holds it
        result = _sweep(str(spec), "-o", str(out))
    assert result.exit_code == 2
    assert f"in use by another sweep (pid {os.getpid()})" in result.stderr
    assert not (out / "runs").exists()


# ---- signals, on a real sweep in a subprocess -----------------------------------------------


def _start(tmp_path: Path, seeds: int) -> tuple[subprocess.Popen[str], Path]:
    spec = write_spec(tmp_path, TINY.format(log=NEAR, seeds=seeds))
    out = tmp_path / "out"
    env = {k: v for k, v in os.environ.items() if k != "FLYLOG_DEBUG"}
    process = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "from flylog.cli.main import main; main()",
            "sweep",
            str(spec),
            "-o",
            str(out),
            "--workers",
            "1",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        start_new_session=True,  # its own process group, as a shell's job
    )
    return process, out


def _wait(process: subprocess.Popen[str], ready) -> None:
    deadline = time.monotonic() + WAIT_S
    while not ready():
        if process.poll() is not None or time.monotonic() > deadline:
            os.killpg(process.pid, signal.SIGKILL)
            _, err = process.communicate()
            pytest.fail(f"the sweep never got there (exit {process.returncode}): {err}")
        time.sleep(0.05)


def _group(pgid: int) -> list[int]:
    """The live (not zombie) processes of the process group ``pgid``."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat.rsplit(")", 1)[1].split()
        if int(fields[2]) == pgid and fields[0] != "Z":
            found.append(int(entry.name))
    return found


def _gone(pgid: int) -> bool:
    deadline = time.monotonic() + 30
    while _group(pgid) and time.monotonic() < deadline:
        time.sleep(0.1)
    return not _group(pgid)


def _cells_running(out: Path) -> bool:
    """A cell has begun (its directory made) after at least one finished."""
    return len(list(out.glob("runs/*"))) >= 2


pytestmark_linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc")


@pytestmark_linux
def test_sigterm_stops_the_sweep_and_says_what_it_kept(tmp_path):
    process, out = _start(tmp_path, seeds=12)
    _wait(process, lambda: any(out.glob("runs/*/cell.json")))
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 128 + signal.SIGTERM, err
    kept = len(list(out.glob("runs/*/cell.json")))
    assert 1 <= kept < 12
    assert f"stopped by SIGTERM: {kept} finished cell(s) kept under" in err
    assert "no output was written" not in err and "Traceback" not in err
    assert list(out.rglob("*.part")) == []
    assert _gone(process.pid)


@pytestmark_linux
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_a_signal_to_the_process_group_leaves_nothing_behind(tmp_path, signum):
    process, out = _start(tmp_path, seeds=12)
    _wait(process, lambda: _cells_running(out))
    os.killpg(process.pid, signum)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 128 + signum, err
    assert "Traceback" not in err, err
    assert list(out.rglob("*.part")) == []
    assert _gone(process.pid)
    if "resource_tracker" in err:
        # Known and not fixed: in about a third of the runs (SIGTERM or SIGHUP to the group)
        # multiprocessing's resource tracker says the pool's five queue semaphores leaked;
        # it unlinks them itself, so nothing is left on the machine, but the line is noise.
        assert "leaked semaphore" in err, err
        pytest.xfail("multiprocessing's resource tracker reported the pool's semaphores")


@pytestmark_linux
def test_workers_end_when_the_parent_is_killed(tmp_path):
    process, out = _start(tmp_path, seeds=12)
    _wait(process, lambda: _cells_running(out))
    assert len(_group(process.pid)) >= 3  # the sweep, its worker, the resource tracker
    process.kill()
    process.communicate(timeout=60)
    assert _gone(process.pid)
