from __future__ import annotations

from pathlib import Path

import pytest

from flylog.io import open_log
from flylog.sweep.cells import sweep_cells
from flylog.sweep.order import estimated_work, longest_first
from flylog.sweep.spec import load_spec

from .conftest import NEAR


def test_cells_go_out_longest_first_and_an_unreadable_log_last(
    tiny_spec: Path, tmp_path: Path
) -> None:
    cells = sweep_cells(load_spec(tiny_spec), tmp_path, [])
    reader = open_log(NEAR)
    span = (reader.end_ns - reader.start_ns) * 1e-9
    # near-obstacle: flies 96 (seeds 0, 1), 160 (seeds 0, 1); bad.mcap: the same four
    assert estimated_work(cells) == pytest.approx([span * 96] * 2 + [span * 160] * 2 + [0.0] * 4)
    got = [(c.input == str(NEAR), c.config.engine.flies, c.seed) for c in longest_first(cells)]
    assert got == [
        (True, 160, 0),
        (True, 160, 1),
        (True, 96, 0),
        (True, 96, 1),
        (False, 96, 0),
        (False, 96, 1),
        (False, 160, 0),
        (False, 160, 1),
    ]
