"""The trajectories of a sensor log: from the simulator's ``flylog.trajectories`` record when
it has one, else (older, filtered or unfinished logs) streamed from the topics."""

import json
from pathlib import Path

import numpy as np
import pytest

from flylog.io import contract, open_log
from flylog.io.scan import TruncatedLogWarning
from flylog.metrics.config import MetricsConfig
from flylog.metrics.score import score_run
from flylog.metrics.tum import export_tum
from flylog.sources import read_truth
from flylog.sources.truth import TrajectorySource, read_poses
from tests.logcopy import copy_log

from .helpers import surface_flies, write_run


def streamed(path: Path):
    found = read_poses(open_log(path), [contract.TRUTH_POSE, contract.ODOM])
    return found[contract.TRUTH_POSE], found[contract.ODOM]


def assert_same(a, b):
    assert np.array_equal(a.t_ns, b.t_ns) and np.array_equal(a.xyt, b.xyt)


def test_the_simulator_records_both_trajectories_exactly_as_its_topics(sensor_log, truth):
    assert truth.source is TrajectorySource.METADATA
    true, odom = streamed(sensor_log)
    assert len(true) == len(odom) == open_log(sensor_log).topics()[contract.ODOM].count > 50
    assert_same(truth.true, true)  # bit for bit: headings as decoded from the quaternions
    assert_same(truth.odom, odom)
    assert not np.array_equal(truth.true.xyt, truth.odom.xyt)  # noisy odometry drifts


def test_a_log_without_the_record_is_read_from_its_topics(sensor_log, truth, tmp_path):
    def drop(meta):
        return {k: v for k, v in meta.items() if k != contract.TRAJECTORIES_METADATA}

    older = copy_log(sensor_log, tmp_path / "older.mcap", metadata=drop)
    got = read_truth(older)
    assert got.source is TrajectorySource.TOPICS
    assert_same(got.true, truth.true)
    assert_same(got.odom, truth.odom)
    assert got.rig == truth.rig and got.scene.text == truth.scene.text


@pytest.mark.parametrize(
    "spoil",
    [
        lambda r: {**r, "version": "0"},  # another layout
        lambda r: {**r, "true": r["true"][:-20]},  # cut JSON
        lambda r: {**r, "odom": json.dumps({**json.loads(r["odom"]), "x": [0.0]})},  # ragged
        lambda r: {  # one pose short of the topic: a filtered log, say
            **r,
            "true": json.dumps({k: v[:-1] for k, v in json.loads(r["true"]).items()}),
        },
    ],
)
def test_a_record_that_does_not_fit_the_topics_is_ignored(sensor_log, truth, tmp_path, spoil):
    def edit(meta):
        return {**meta, contract.TRAJECTORIES_METADATA: spoil(meta[contract.TRAJECTORIES_METADATA])}

    got = read_truth(copy_log(sensor_log, tmp_path / "spoilt.mcap", metadata=edit))
    assert got.source is TrajectorySource.TOPICS
    assert_same(got.true, truth.true)


def test_a_truncated_log_is_read_from_its_topics_up_to_the_damage(sensor_log, truth, tmp_path):
    cut = tmp_path / "cut.mcap"
    data = copy_log(sensor_log, tmp_path / "chunky.mcap", chunk_size=64 * 1024).read_bytes()
    cut.write_bytes(data[: len(data) * 2 // 3])
    with pytest.warns(TruncatedLogWarning):
        got = read_truth(cut)
    assert got.source is TrajectorySource.TOPICS
    n = len(got.true)
    assert 0 < n < len(truth.true)
    assert_same(got.true, type(truth.true)(truth.true.t_ns[:n], truth.true.xyt[:n]))


def test_metrics_are_the_same_from_the_record_and_from_the_topics(sensor_log, truth, tmp_path):
    times = [200_000_000, 700_000_000]
    run = write_run(
        tmp_path / "run.mcap", [(t, surface_flies(truth, t, scale=1.03)) for t in times]
    )

    def drop(meta):
        return {k: v for k, v in meta.items() if k != contract.TRAJECTORIES_METADATA}

    older = copy_log(sensor_log, tmp_path / "older.mcap", metadata=drop)
    config = MetricsConfig(tau=0.04)
    a = score_run(run, sensor_log, config)
    b = score_run(run, older, config)
    assert a.snapshots == b.snapshots and a.obstacles == b.obstacles
    skip = {"log", "log_fingerprint", "metrics_wall_s"}  # two files, one truth
    assert {k: v for k, v in a.summary.items() if k not in skip} == {
        k: v for k, v in b.summary.items() if k not in skip
    }


def test_tum_export_is_the_same_from_the_record_and_from_the_topics(sensor_log, tmp_path):
    def drop(meta):
        return {k: v for k, v in meta.items() if k != contract.TRAJECTORIES_METADATA}

    older = copy_log(sensor_log, tmp_path / "older.mcap", metadata=drop)
    new = export_tum(sensor_log, tmp_path / "new")
    old = export_tum(older, tmp_path / "old")
    assert set(new) == set(old) == {"true", "odom"}
    for name in new:
        assert new[name].read_bytes() == old[name].read_bytes()
