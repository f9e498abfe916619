"""The closed-loop experiment's planner overrides and how its set-up describes them."""

from flylog.experiments.closed_loop import _config, _describe_planner
from flylog.experiments.common import ExperimentOptions
from flylog.planner import PlannerConfig

OPTIONS = ExperimentOptions(seeds=1, flies=300)


def test_planner_overrides_reach_every_run_with_its_seed_and_flies():
    config = _config(OPTIONS, 3, {"planner.obstacle_weight": 1.0, "planner.lookahead": 0.0})
    assert config.seed == 3 and config.engine.flies == 300
    assert config.planner.obstacle_weight == 1.0 and config.planner.lookahead == 0.0
    assert _config(OPTIONS, 0, {}).planner == PlannerConfig()


def test_setup_names_the_field_and_the_overrides():
    paper = PlannerConfig(obstacle_weight=1.0, lookahead=0.0)
    text = _describe_planner(paper, {"planner.obstacle_weight": 1.0})
    assert "Dirichlet obstacles (obstacle_weight 1, the paper's form)" in text
    assert "steers along −∇U at the robot" in text
    assert text.endswith("(overridden here: planner.obstacle_weight = 1.0)")
    robin = _describe_planner(PlannerConfig(obstacle_weight=0.03, lookahead=0.5), {})
    assert "obstacles weighted 0.03 among a free cell's neighbours" in robin
    assert "steers at the point 0.5 m down the descent path" in robin
    assert "overridden" not in robin


def test_setup_names_the_sonar_free_cones_when_they_are_on():
    on = _describe_planner(PlannerConfig(sonar_free_margin=0.2), {})
    assert "every sonar's cone up to its echo (its maximum range without one) less 0.2 m" in on
    assert "sonar's cone" not in _describe_planner(PlannerConfig(sonar_clears=False), {})
