import dataclasses

import pytest

from flylog.datasets.run import import_dataset
from flylog.errors import LogError
from flylog.io import contract
from flylog.io.reader import open_log
from flylog.metrics.score import score_run
from flylog.replay.config import ReplayConfig
from flylog.replay.run import replay
from flylog.sources.inputs import DatasetLogWarning
from tests.datasets.layouts import write_middlebury_scene

SMALL = dataclasses.replace(
    ReplayConfig(), engine=dataclasses.replace(ReplayConfig().engine, flies=600)
)


@pytest.fixture(scope="module")
def plane_log(tmp_path_factory):
    folder = tmp_path_factory.mktemp("plane")
    write_middlebury_scene(folder / "plane")
    (log,) = import_dataset("middlebury", folder / "plane", folder / "plane.mcap")
    return log.path


def test_a_one_frame_log_replays_without_odometry_mount_or_planner_with_warnings(
    plane_log, tmp_path
):
    with pytest.warns(DatasetLogWarning) as caught:
        summary = replay(plane_log, tmp_path / "run.mcap", SMALL)
    said = " ".join(str(w.message) for w in caught)
    assert "no robot geometry" in said and "without proprioception" in said
    assert "without a planner" in said
    assert summary.status == "off" and summary.frames == 1
    # the default (asynchronous) gives the one pair one frame period of virtual compute
    period = 1 / 15.0
    spent = summary.evaluations / SMALL.evals_per_second
    one = SMALL.generation_cost_ns(SMALL.engine.max_evaluations) / 1e9
    assert period <= spent + one and spent <= period + one
    run = open_log(tmp_path / "run.mcap")
    assert contract.PLANNER_COMMAND not in run.topics()
    meta = run.metadata()[contract.REPLAY_METADATA]
    assert meta["ground_test"] == "false" and meta["planner"] == "false"
    assert run.topics()[contract.FLIES].count >= 1


def test_generations_per_frame_runs_that_many_on_the_one_frame_and_scores_it(plane_log, tmp_path):
    config = dataclasses.replace(SMALL, generations_per_frame=40)
    with pytest.warns(DatasetLogWarning):
        summary = replay(plane_log, tmp_path / "run.mcap", config)
    assert summary.generations == 40
    result = score_run(tmp_path / "run.mcap", plane_log)
    s = result.summary
    assert s["truth_images"] == 1 and s["scored_points"] > 50
    # a textured plane: the flies taken find it (measured, sub-pixel, seeds 0-2: bad2 0,
    # precision 1.0 (τ = 5 % of the depth is 0.62 px here), coverage and recall 0.55-0.70;
    # on whole pixels precision 0.92-0.95, coverage and recall 0.80-0.85)
    assert s["bad2"] <= 0.05 and s["precision"] >= 0.95
    assert s["coverage"] >= 0.5 and s["recall"] >= 0.5
    assert s["disparity_error_median_px"] < 0.5
    assert s["sgbm_dense_bad2"] is None  # a flies run has no dense map
    assert result.snapshots[-1]["bad2"] == s["bad2"]


def test_sgbm_runs_are_scored_on_their_points_and_densely(plane_log, tmp_path):
    config = dataclasses.replace(SMALL, stereo=type(SMALL.stereo)("sgbm"))
    config = dataclasses.replace(config, sgbm=dataclasses.replace(config.sgbm, num_disparities=16))
    with pytest.warns(DatasetLogWarning):
        replay(plane_log, tmp_path / "sgbm.mcap", config)
    s = score_run(tmp_path / "sgbm.mcap", plane_log).summary
    assert s["scored_points"] > 100 and s["bad2"] <= 0.05
    assert s["sgbm_dense_bad2"] <= 0.05 and s["sgbm_dense_density"] >= 0.5


def test_a_goal_gives_the_planner_back(plane_log, tmp_path):
    with pytest.warns(DatasetLogWarning):
        summary = replay(plane_log, tmp_path / "run.mcap", SMALL, goal=(3.0, 0.0))
    assert summary.status != "off"
    assert contract.PLANNER_COMMAND in open_log(tmp_path / "run.mcap").topics()


def test_metrics_refuse_an_imported_log_without_ground_truth_images(tmp_path):
    write_middlebury_scene(tmp_path / "plane", truth=False)
    (log,) = import_dataset("middlebury", tmp_path / "plane", tmp_path / "plane.mcap")
    with pytest.warns(DatasetLogWarning):
        replay(log.path, tmp_path / "run.mcap", dataclasses.replace(SMALL, generations_per_frame=2))
    with pytest.raises(LogError, match="without /truth/disparity or /truth/depth; it holds"):
        score_run(tmp_path / "run.mcap", log.path)
