from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from flylog.cli.main import cli
from flylog.config import replace_dotted
from flylog.metrics.score import score_run
from flylog.metrics.tables import SUMMARY_COLUMNS, read_summary
from flylog.replay.config import ReplayConfig
from flylog.replay.run import replay

from .pages import checked_page

LOG = Path(__file__).resolve().parents[2] / "fixtures" / "logs" / "near-obstacle.mcap"


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("run") / "run.mcap"
    config = replace_dotted(ReplayConfig(), {"engine.flies": 200, "generations_per_frame": 1})
    replay(LOG, out, config)
    return out


def test_the_page_has_every_section_and_decodable_images(run: Path, tmp_path: Path) -> None:
    page = tmp_path / "report.html"
    got = CliRunner().invoke(cli, ["report", str(run), "--log", str(LOG), "-o", str(page)])
    assert got.exit_code == 0, got.output
    headings, images, tags = checked_page(page)
    assert headings == ["Summary", "Map", "Left frames", "Over time", "Configuration"]
    assert len(images) == 3  # map, frames, curves
    text = page.read_text(encoding="utf-8")
    assert '<td class="text">precision</td>' in text and '"flies": 200' in text
    assert '<p class="verdict">' in text and "The obstacle flies reach F" in text
    assert "<details><summary>The run&#x27;s effective configuration" in text  # folded
    # A row per summary column holding a value: none of "—" (a replay has no time to goal)
    summary = score_run(run, LOG).summary
    shown = [
        c.name
        for c in SUMMARY_COLUMNS
        if c.name not in ("run", "log", "log_fingerprint", "run_config", "metrics_config")
        and summary[c.name] is not None
        and summary[c.name] == summary[c.name]  # not NaN
    ]
    assert "time_to_goal_s" not in shown and "time_to_goal_s" not in text
    assert sum(1 for t, _ in tags if t == "tr") == 1 + len(shown)
    assert "<td>—</td>" not in text


def test_a_run_without_its_log_is_an_error_and_leaves_nothing(run: Path, tmp_path: Path) -> None:
    page = tmp_path / "report.html"
    got = CliRunner().invoke(cli, ["report", str(run), "-o", str(page)])
    assert got.exit_code == 2 and "error" in got.output
    assert list(tmp_path.iterdir()) == []


def test_the_metrics_outputs_are_shown_as_they_are(run: Path, tmp_path: Path) -> None:
    metrics = tmp_path / "m.parquet"
    scored = CliRunner().invoke(
        cli, ["metrics", str(run), "--log", str(LOG), "-o", str(metrics), "--tau", "0.01"]
    )
    assert scored.exit_code == 0, scored.output
    # the printed table: no row without a value (a replay has no time to goal), 80 columns
    assert "time to goal" not in scored.output and "—" not in scored.output
    assert max(len(line) for line in scored.output.splitlines()) <= 80
    precision = read_summary(metrics)["precision"]
    assert score_run(run, LOG).summary["precision"] != precision  # tau matters here
    page = tmp_path / "report.html"
    args = ["report", str(run), "--log", str(LOG), "--metrics", str(metrics), "-o", str(page)]
    got = CliRunner().invoke(cli, args)
    assert got.exit_code == 0, got.output
    headings, images, _ = checked_page(page)
    assert len(images) == 3 and "Over time" in headings
    text = page.read_text(encoding="utf-8")
    # the table's own precision (tau 0.2), not a score made now with the default tau
    assert f'<td class="text">precision</td><td>{precision:.4g}</td>' in text
