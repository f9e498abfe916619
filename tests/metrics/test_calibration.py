"""The flies' confidence and its calibration (flylog.fly.confidence,
flylog.metrics.calibration), and the packaged model (flylog/fly/confidence.json)."""

import json
import math
from importlib import resources

import numpy as np
import pytest

from flylog.fly import confidence as cf
from flylog.metrics.calibration import (
    default_engine_digest,
    expected_calibration_error,
    fit_isotonic,
    fit_logistic,
    reliability,
)
from flylog.metrics.config import MetricsConfig

# The packaged model's target on the runs it was not fitted on, pooled (docs/export.md).
HELD_OUT_ECE = 0.05


def test_the_packaged_model_is_current_for_the_default_configuration():
    text = resources.files("flylog.fly").joinpath(cf.PACKAGED).read_text(encoding="utf-8")
    model = cf.load()
    assert model is not None and json.loads(text)["format"] == cf.FORMAT
    assert model.to_json() == text  # written by `flylog calibrate` in the current format
    assert model.engine == default_engine_digest()
    assert model.tau == MetricsConfig().tau
    provenance = json.loads(model.provenance)
    fitted = {(r["scene"], r["seed"]) for r in provenance["fit"]}
    fitted_seeds = {seed for _, seed in fitted}
    assert provenance["held_out"]
    for r in provenance["held_out"]:  # other seeds (and, some, other scenes)
        assert r["seed"] not in fitted_seeds
    assert {r["scene"] for r in provenance["held_out"]} - {s for s, _ in fitted}
    assert provenance["held_out_ece_pooled"] <= HELD_OUT_ECE


def test_invalid_flies_have_no_confidence_and_a_passing_candidate_more():
    model = cf.load()
    fitness = np.array([0.0, 1.0, 5.0, 2.0, -1.0, 9.0])
    p = model.of(fitness, None, None)
    assert p[0] == 0 and p[4] == 0
    assert p[1] < p[3]  # the lowest ranks are the least trusted
    assert ((p > 0) & (p <= 1))[[1, 2, 3, 5]].all()
    # an obstacle candidate that passes the rule's distinctness test is trusted more
    age = np.full(6, 5.0)
    distinct = np.array([np.nan, np.nan, np.nan, np.nan, np.nan, 3.0])
    assert model.of(fitness, age, distinct)[5] > model.of(fitness, age, None)[5]


def test_fitness_quantile_is_the_mean_rank_among_valid_flies():
    q = cf.fitness_quantile(np.array([3.0, 0.0, 1.0, 3.0, 2.0]))
    np.testing.assert_allclose(q, [3.5 / 4, 0, 1 / 4, 3.5 / 4, 2 / 4])
    fitness = np.round(np.random.default_rng(0).normal(1, 1, 2000), 2)  # many ties
    valid = fitness[fitness > 0]
    below = (valid[None, :] < valid[:, None]).sum(axis=1)
    equal = (valid[None, :] == valid[:, None]).sum(axis=1)
    expected = np.zeros(len(fitness))
    expected[fitness > 0] = (below + (equal + 1) / 2) / len(valid)
    np.testing.assert_array_equal(cf.fitness_quantile(fitness), expected)


def test_ece_and_reliability_of_known_cases():
    rng = np.random.default_rng(0)
    p = rng.uniform(0, 1, 200_000)
    y = rng.uniform(0, 1, len(p)) < p  # calibrated by construction
    assert expected_calibration_error(p, y) < 0.005
    assert expected_calibration_error(np.full(10, 0.9), np.arange(10) < 6) == pytest.approx(0.3)
    rows = reliability(np.array([0.05, 0.05, 0.95]), np.array([1, 0, 1]))
    assert [r["flies"] for r in rows] == [2, 0, 0, 0, 0, 0, 0, 0, 0, 1]
    assert rows[0]["on_surface_share"] == 0.5 and math.isnan(rows[1]["mean_confidence"])
    assert math.isnan(expected_calibration_error(np.empty(0), np.empty(0)))


def test_isotonic_fit_is_monotone_and_keeps_each_blocks_mean():
    x = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    y = np.array([0.0, 1.0, 0.0, 1.0, 1.0, 0.0])
    kx, kv = fit_isotonic(x, y)
    assert np.all(np.diff(kv) >= 0)
    np.testing.assert_allclose(kv, [0.0, 0.5, 2 / 3])  # blocks {1}, {2, 3}, {4, 5, 6}
    np.testing.assert_allclose(kx, [1.0, 2.5, 5.0])


def test_logistic_fit_recovers_known_weights():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(100_000, 2))
    p = 1 / (1 + np.exp(-(0.5 + 2.0 * x[:, 0] - 1.0 * x[:, 1])))
    y = rng.uniform(size=len(p)) < p
    np.testing.assert_allclose(fit_logistic(x, y), [0.5, 2.0, -1.0], atol=0.05)


def test_a_model_file_that_is_not_one_is_refused(tmp_path):
    from flylog.errors import ConfigError

    bad = tmp_path / "m.json"
    bad.write_text('{"format": "flylog.confidence/0"}')
    with pytest.raises(ConfigError, match="format"):
        cf.load(bad)
    bad.write_text(json.dumps({"format": cf.FORMAT, "kind": "isotonic", "features": ["x"]}))
    with pytest.raises(ConfigError, match=r"m\.json"):
        cf.load(bad)


@pytest.fixture(scope="module")
def corridor_run(tmp_path_factory):
    from flylog.replay.run import replay
    from tests.replay.test_replay import CORRIDOR, SMALL

    return replay(CORRIDOR, tmp_path_factory.mktemp("cal") / "run.mcap", SMALL).output, CORRIDOR


def test_labels_agree_with_the_fly_metrics_and_the_rule_comparison_counts_alike(corridor_run):
    from flylog.metrics.calibration import compare_with_rule, labelled_run, score_confidence
    from flylog.metrics.score import score_run

    run, log = corridor_run
    data = labelled_run(run, log, MetricsConfig())
    summary = score_run(run, log, MetricsConfig()).summary
    # the rule's flies among the judged ones are the flies the precision counts
    assert data.on_surface[data.obstacle].mean() == pytest.approx(summary["precision"])
    model = cf.load()
    compared = compare_with_rule(data, model)
    assert compared.points == int(data.obstacle.sum()) > 0
    assert compared.rule_precision == pytest.approx(summary["precision"])
    assert 0 <= compared.confidence_precision <= 1
    score = score_confidence(run, log, MetricsConfig(), model)
    assert score.ece == pytest.approx(summary["confidence_ece"])
    assert score.flies == data.flies == summary["confidence_flies"]
    assert sum(r["flies"] for r in score.table) == data.flies
