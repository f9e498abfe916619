"""The page of a run on an imported dataset's log: the verdict, each fly's disparity error
on the left image beside the true disparity and SGBM's dense map and error, the histogram."""

from __future__ import annotations

from pathlib import Path

from click.testing import CliRunner

from flylog.cli.main import cli
from flylog.datasets.run import import_dataset
from tests.datasets.layouts import write_middlebury_scene

from .pages import checked_page


def test_a_dataset_run_is_drawn_against_its_ground_truth(tmp_path: Path) -> None:
    write_middlebury_scene(tmp_path / "data" / "Plane")
    (log,) = import_dataset("middlebury", tmp_path / "data", tmp_path / "plane.mcap")
    runner = CliRunner()
    for engine, run in (("flies", "run.mcap"), ("sgbm", "sgbm.mcap")):
        args = ["replay", str(log.path), "-o", str(tmp_path / run), "--engine", engine]
        got = runner.invoke(cli, [*args, "--flies", "400"])
        assert got.exit_code == 0, got.output
    got = runner.invoke(cli, ["report", str(tmp_path / "run.mcap"), "--log", str(log.path)])
    assert got.exit_code == 0, got.output
    page = tmp_path / "run.html"  # beside the run without -o
    headings, images, _ = checked_page(page)
    assert headings == [
        "Summary",
        "Disparity error on the left image",
        "Error histogram",
        "Configuration",
    ]
    assert len(images) == 2 and all(i.shape[1] > 800 for i in images)
    text = page.read_text(encoding="utf-8")
    assert "of the obstacle flies lie within 2 px of the true disparity" in text
    assert "<td>—</td>" not in text and "bad2" in text and "SGBM&#x27;s dense map" in text
    got = runner.invoke(cli, ["report", str(tmp_path / "sgbm.mcap"), "--log", str(log.path)])
    assert got.exit_code == 0, got.output
    text = (tmp_path / "sgbm.html").read_text(encoding="utf-8")
    assert "of the SGBM points lie within 2 px" in text and "obstacle flies" not in text
