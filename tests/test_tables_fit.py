"""flylog's terminal tables at 80 columns: every cell whole, no line wider than the
terminal (cli.tables: as they are, turned, or a block per row)."""

from __future__ import annotations

import io

from rich.console import Console

from flylog.cli.tables import print_fitted

# The closed-loop experiment's columns (flylog.experiments.closed_loop) and cells as wide
# as its figures print.
CLOSED_LOOP = [
    "scene",
    "success (goal, no collision)",
    "goal reached",
    "planner reported the goal",
    "no collision",
    "inside the walls",
    "ended STUCK",
    "time to goal (s)",
    "path length (m)",
    "min clearance (m)",
    "odometry ATE (m)",
    "true distance to the goal at the end (m)",
    "odometric drift at the end (m)",
    "fly precision",
    "fly recall",
]
SWEEP = [
    "variant",
    "engine.flies",
    "cells ok",
    "failed",
    "precision",
    "recall",
    "F-score",
    "latency (s)",
    "goal reached",
    "clearance (m)",
    "ATE (m)",
]


def _printed(header, rows, width=80, **kwargs) -> str:
    out = io.StringIO()
    console = Console(file=out, width=width, force_terminal=False)
    print_fitted(console, "title", header, rows, **kwargs)
    return out.getvalue()


def _whole(text: str, rows) -> None:
    assert max(len(line) for line in text.splitlines()) <= 80
    assert "…" not in text
    for row in rows:
        for cell in row:
            assert cell in text, cell


def test_the_closed_loop_table_is_read_whole_at_80_columns() -> None:
    rows = [
        [
            "corridor",
            "10/10",
            "10/10",
            "9/10",
            "10/10",
            "10/10",
            "0/10",
            "24.3 ± 1.2",
            "10.12 ± 0.05",
            "0.41 ± 0.03",
            "0.082 ± 0.031",
            "0.153 ± 0.021",
            "0.231 ± 0.101",
            "0.874 ± 0.012",
            "0.512 ± 0.034",
        ],
        [
            "clutter",
            "8/10",
            "9/10",
            "9/10",
            "9/10",
            "10/10",
            "1/10",
            "31.9 ± 4.4",
            "12.87 ± 0.91",
            "0.22 ± 0.08",
            "0.143 ± 0.077",
            "0.190 ± 0.302",
            "0.412 ± 0.233",
            "0.803 ± 0.044",
            "0.433 ± 0.051",
        ],
    ]
    text = _printed(CLOSED_LOOP, rows, right=range(1, len(CLOSED_LOOP)))
    _whole(text, rows)
    assert "(a column per row)" in text  # turned: a header per scene


def test_the_sweep_summary_is_read_whole_at_80_columns() -> None:
    rows = [
        [
            v,
            str(f),
            "2",
            "0",
            "0.702 ± 0.101",
            "0.301 ± 0.12",
            "0.421 ± 0.09",
            "0.512 ± 0.062",
            "0.000 ± 0.000",
            "0.637 ± 0.042",
            "0.0004 ± 0.0004",
        ]
        for v in ("per-frame", "no-sonar")
        for f in (300, 600, 1200, 2400)
    ]
    text = _printed(SWEEP, rows, right=range(2, len(SWEEP)), key_columns=2)
    _whole(text, rows)
    assert "(a column per row, 1 of " in text  # turned, in tables side by side


def test_a_table_that_fits_is_printed_as_it_is() -> None:
    rows = [["precision", "0.7425", ""], ["path length", "0.4991", "m"]]
    text = _printed(["metric", "value", "unit"], rows, right=[1])
    _whole(text, rows)
    assert "a column per row" not in text and "metric" in text
