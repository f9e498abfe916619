from __future__ import annotations

import math
from pathlib import Path

from click.testing import CliRunner

from flylog.cli.main import cli
from flylog.report.sweep import metric_lines
from flylog.sweep.runner import SweepResult
from tests.report.pages import checked_page


def test_sweep_page_plots_each_grid_key_and_lists_every_cell(
    pool_sweep: SweepResult, tmp_path: Path
) -> None:
    page = tmp_path / "sweep.html"
    out = pool_sweep.results.parent
    got = CliRunner().invoke(cli, ["report", str(out), "-o", str(page)])
    assert got.exit_code == 0, got.output
    headings, images, tags = checked_page(page)
    assert headings == ["Metrics against engine.flies", "Results"]
    assert len(images) == 1
    rows = [t for t, attrs in tags if t == "tr"]
    assert len(rows) == 1 + 8
    assert sum(1 for t, a in tags if t == "tr" and a.get("class") == "failed") == 4


def test_a_line_per_variant_at_each_grid_value(pool_sweep: SweepResult) -> None:
    lines = metric_lines(pool_sweep.rows, "engine.flies", "precision")
    ((variant, (xs, mean, sd)),) = lines.items()
    assert variant == "per-frame" and xs == [96, 160]
    a, b = (r["precision"] for r in pool_sweep.rows[2:4])
    assert math.isclose(mean[1], (a + b) / 2) and math.isclose(sd[1], abs(a - b) / math.sqrt(2))
