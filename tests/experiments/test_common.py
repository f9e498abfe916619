"""Statistics over seeds, table cells, Markdown, options and the experiments' names."""

import json
import math

import numpy as np
import pytest

from flylog.errors import ConfigError
from flylog.experiments import EXPERIMENTS, experiment_names
from flylog.experiments.common import (
    Column,
    Count,
    ExperimentOptions,
    Spread,
    Table,
    format_cell,
    spread,
    write_results,
)
from flylog.experiments.markdown import markdown_table


def test_spread_is_mean_and_sample_std_of_the_finite_values():
    s = spread([1.0, 2.0, 3.0, math.nan, None])
    assert s.mean == pytest.approx(2.0)
    assert s.std == pytest.approx(1.0)  # sample std (ddof=1) of 1, 2, 3
    assert s.n == 3


def test_spread_of_one_value_has_zero_std_and_of_none_is_nan():
    assert spread([4.5]) == Spread(4.5, 0.0, 1)
    empty = spread([math.nan])
    assert empty.n == 0 and math.isnan(empty.mean)


def test_cells_format_spreads_counts_and_missing_values():
    assert format_cell(Spread(0.5, 0.25, 3), ".2f") == "0.50 ± 0.25"
    assert format_cell(Spread(0.5, 0.0, 1), ".1f") == "0.5"
    assert format_cell(Spread(math.nan, math.nan, 0), ".1f") == "–"
    assert format_cell(Count(4, 5), "") == "4/5"
    assert format_cell(math.nan, ".2f") == "–"
    assert format_cell(1.23456, ".2f") == "1.23"
    assert format_cell("async", ".2f") == "async"


def test_markdown_table_has_a_header_rule_and_one_line_per_row():
    table = Table(
        "t",
        (Column("mode", "pipeline"), Column("x", "x (s)", ".1f")),
        ({"mode": "a", "x": Spread(1.0, 0.5, 2)}, {"mode": "b", "x": 2.0}),
    )
    assert markdown_table(table).splitlines() == [
        "| pipeline | x (s) |",
        "|---|---|",
        "| a | 1.0 ± 0.5 |",
        "| b | 2.0 |",
    ]


def test_results_json_holds_plain_numbers(tmp_path):
    table = Table("t", (Column("x", "x"),), ({"x": Spread(1.0, 0.5, 2), "k": Count(1, 2)},))
    runs = [{"seed": 0, "v": np.float64(0.25), "nan": math.nan, "flag": np.bool_(True)}]
    data = json.loads(write_results(tmp_path, ExperimentOptions(seeds=2), table, runs).read_text())
    assert data["runs"] == [{"seed": 0, "v": 0.25, "nan": None, "flag": True}]
    assert data["table"] == [{"x": {"mean": 1.0, "std": 0.5, "n": 2}, "k": {"k": 1, "n": 2}}]
    assert data["options"]["seeds"] == 2
    assert data["options"]["resolution"] == [320, 240]
    assert data["options"]["scenes"] == "fixtures/scenes"  # wherever the checkout lies
    elsewhere = ExperimentOptions(scenes=tmp_path)
    data = json.loads(write_results(tmp_path, elsewhere, table, runs).read_text())
    assert data["options"]["scenes"] == str(tmp_path)


def test_options_reject_tiny_images_and_unknown_scenes(tmp_path):
    with pytest.raises(ConfigError, match="at least 16x16"):
        ExperimentOptions(resolution=(8, 8))
    with pytest.raises(ConfigError, match="duration must be positive"):
        ExperimentOptions(duration=0.0)
    with pytest.raises(ConfigError, match="no such scene file"):
        ExperimentOptions(scenes=tmp_path).scene_path("turn")


def test_experiment_names():
    assert experiment_names("all") == list(EXPERIMENTS)
    assert experiment_names("sonar") == ["sonar"]
    with pytest.raises(ConfigError, match="unknown experiment 'fig12': choose one of"):
        experiment_names("fig12")
