"""Every experiment in a tiny configuration (1 seed, 96×72, 1 s, 300 flies): the summary,
its figures and results.json exist and hold numbers; the CLI prints the table."""

import json
import math

import pytest
from click.testing import CliRunner

from flylog.cli.main import cli
from flylog.experiments import EXPERIMENTS
from flylog.experiments.common import ExperimentOptions, Spread
from flylog.experiments.parallel import run_experiment

TINY = ExperimentOptions(seeds=1, resolution=(96, 72), duration=1.0, flies=300)
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    out = tmp_path_factory.mktemp("experiments")
    steps: dict[str, list[tuple[float, float]]] = {}
    done = {
        name: run_experiment(
            name, out, TINY, on_progress=lambda d, t, n=name: steps.setdefault(n, []).append((d, t))
        )
        for name in EXPERIMENTS
    }
    return out, done, steps


@pytest.mark.parametrize("name", list(EXPERIMENTS))
def test_summary_figures_and_results_are_written(results, name):
    out, done, steps = results
    result = done[name]
    here = out / name
    assert result.summary == here / "summary.md"
    text = result.summary.read_text()
    assert text.startswith("# ")
    assert "|---|" in text
    assert result.figures
    for png in result.figures:
        assert png.parent == here
        assert f"]({png.name})" in text
        data = png.read_bytes()
        assert data.startswith(PNG_MAGIC)
        assert len(data) < 200_000
    saved = json.loads((here / "results.json").read_text())
    assert len(saved["runs"]) == len(result.runs) >= 2
    assert len(saved["table"]) == len(result.table.rows) >= 2
    assert not (here / "runs").exists()  # logs are deleted unless kept
    assert steps[name][0][0] == 0.0 and steps[name][-1][0] == steps[name][-1][1]


def test_proprioception_scores_are_numbers(results):
    _, done, _ = results
    for row in done["proprioception"].table.rows:
        for key in ("precision", "recall"):
            assert isinstance(row[key], Spread) and row[key].n == 1
            assert 0.0 <= row[key].mean <= 1.0


def test_latency_rows_and_delays(results):
    _, done, _ = results
    result = done["latency"]
    modes = [r["mode"] for r in result.table.rows]
    assert modes[0] == "async flies" and modes[1].startswith("sync flies")
    turn = [r for r in result.runs if r["scene"] == "turn"]
    assert all(d >= 0.0 for r in turn for d in r["reaction_frames"] + r["detection_frames"])
    assert all(r["entered_view"] >= 1 for r in turn)  # the robot turns past obstacles
    corridor = [r for r in result.runs if r["scene"] == "corridor"]
    assert all(0.0 <= r["precision"] <= 1.0 for r in corridor)


def test_closed_loop_reports_each_scene(results):
    _, done, _ = results
    rows = done["closed-loop"].table.rows
    assert [r["scene"] for r in rows] == ["corridor", "clutter", "doorways", "doorways 192×144"]
    assert all(r["planner_goal"].n == r["success"].n == 1 for r in rows)
    for r in done["closed-loop"].runs:
        # 1 s cannot reach a goal 10 m away
        assert r["goal_reached"] is False and r["success"] is False
        assert math.isfinite(r["path_length_m"]) and r["path_length_m"] < 1.0
        # the true and odometric positions part by at most a few centimetres in 1 s
        assert 0.0 <= r["final_drift_m"] < 0.05


def test_sonar_counts_the_post(results):
    _, done, _ = results
    for r in done["sonar"].runs:
        assert r["post_flies_median"] >= 0.0
        assert isinstance(r["post_detected"], bool)


def test_cli_runs_an_experiment_and_prints_its_table(tmp_path):
    args = [
        "experiment",
        "sonar",
        "-o",
        str(tmp_path),
        "--seeds",
        "1",
        "--resolution",
        "96x72",
        "--duration",
        "1",
        "--flies",
        "300",
    ]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    assert "with sonar fusion" in result.output
    assert (tmp_path / "sonar" / "summary.md").is_file()


def test_cli_rejects_an_unknown_experiment(tmp_path):
    result = CliRunner().invoke(cli, ["experiment", "fig12", "-o", str(tmp_path)])
    assert result.exit_code == 2
    assert "unknown experiment 'fig12'" in result.output
    assert "closed-loop" in result.output
    assert not any(tmp_path.iterdir())
