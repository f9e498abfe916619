"""A pool worker's process settings: warnings as one line, the parent's death followed."""

from __future__ import annotations

import subprocess
import sys
import warnings

from flylog.process import one_line_warnings
from flylog.sweep.executors import ProcessPool


def _warns(text: str) -> str:
    warnings.warn(text, UserWarning, stacklevel=1)
    return text


def test_a_workers_warning_is_one_line(capfd):
    pool = ProcessPool(1, warm=False)
    try:
        assert list(pool.map_unordered(_warns, ["a log lost\n3 messages"])) == [
            (0, "a log lost\n3 messages")
        ]
    finally:
        pool.close()
    err = capfd.readouterr().err
    assert "warning: a log lost 3 messages\n" in err
    assert ".py:" not in err and "UserWarning" not in err


def test_the_one_line_format():
    previous = warnings.formatwarning
    try:
        one_line_warnings()
        shown = warnings.formatwarning("x\ny", UserWarning, "f.py", 3)
    finally:
        warnings.formatwarning = previous
    assert shown == "warning: x y\n"


def test_a_worker_asks_for_its_parents_death_signal():
    # in a process of its own (the setting would outlive the test in this one)
    code = "import os; from flylog.process import end_with_parent as e; print(e(os.getppid()))"
    how = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.strip()
    assert how == ("prctl" if sys.platform.startswith("linux") else "watchdog")
