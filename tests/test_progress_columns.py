"""The drawn progress bar counts whole things in whole numbers and seconds of log to 0.1 s."""

from __future__ import annotations

import io

import pytest
from rich.console import Console

from flylog.cli.progress import drawn_progress_bar


@pytest.mark.parametrize(
    ("unit", "shown"), [("cells", "3/10"), ("logs", "3/10"), ("s", "3.0/10.0 s")]
)
def test_the_count_column_fits_the_unit(unit, shown):
    out = io.StringIO()
    console = Console(file=out, force_terminal=True, width=120, color_system=None)
    with drawn_progress_bar("work", unit, console) as update:
        update(3, 10)
    text = out.getvalue()
    assert shown in text
    if unit != "s":
        assert "3.0" not in text
