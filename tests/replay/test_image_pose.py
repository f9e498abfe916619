"""The flies are expressed where the robot was when their images were taken."""

import math
from collections import deque

import numpy as np
import pytest

from flylog.geometry import Pose2D, StereoRig
from flylog.replay.config import ReplayConfig
from flylog.replay.pipeline import FlyPipeline, pose_at
from flylog.sensors import OdomReading, StereoPair

MS = 1_000_000


def _turning(n: int, rate: float = 0.5) -> deque[OdomReading]:
    """Odometry at 50 Hz of a robot turning on the spot at ``rate`` rad/s from heading 3."""
    return deque(
        OdomReading(20 * MS * i, Pose2D(0.0, 0.0, math.remainder(3.0 + rate * 0.02 * i, math.tau)))
        for i in range(n)
    )


def test_pose_at_interpolates_between_the_readings_around_the_stamp_and_past_the_newest():
    readings = deque(
        [OdomReading(0, Pose2D(0.0, 0.0, 0.0)), OdomReading(20 * MS, Pose2D(0.2, -0.1, 0.4))]
    )
    mid = pose_at(readings, 5 * MS)
    assert (mid.x, mid.y, mid.theta) == pytest.approx((0.05, -0.025, 0.1))
    # past the newest: the newest two's motion carried on, for one interval at most
    ahead = pose_at(readings, 30 * MS)
    assert (ahead.x, ahead.y, ahead.theta) == pytest.approx((0.3, -0.15, 0.6))
    far = pose_at(readings, 100 * MS)
    assert (far.x, far.y, far.theta) == pytest.approx((0.4, -0.2, 0.8))
    assert pose_at(deque(list(readings)[:1]), 30 * MS) == readings[0].pose  # one: itself
    assert pose_at(readings, -5 * MS) == readings[0].pose  # before the oldest kept: the oldest
    # across ±pi the heading goes the short way
    turning = _turning(20)
    between = pose_at(turning, 290 * MS)  # readings 14 and 15: 3.14 and 3.15 - 2 pi rad
    assert between.theta == pytest.approx(math.remainder(3.145, math.tau))


def test_published_flies_carry_the_pose_of_their_images_not_the_newest_odometry():
    rig = StereoRig(width=64, height=48, focal_px=50.0)
    config = ReplayConfig(seed=0)
    pipeline = FlyPipeline(config, rig, Pose2D(0.0, 0.0, 3.0), (5.0, 0.0), lambda *a: None)
    try:
        readings = _turning(8)
        for r in list(readings)[:4]:  # odometry up to 60 ms
            pipeline.deliver(r)
        images = np.full((48, 64, 3), 128, dtype=np.uint8)
        pipeline.deliver(StereoPair(50 * MS, images, images))  # taken at 50 ms
        for r in list(readings)[4:]:  # odometry goes on to 140 ms while the engine works
            pipeline.deliver(r)
        pipeline.generation(False)
        pipeline.publish(150 * MS)
        at_images = pose_at(readings, 50 * MS)
        assert pipeline.published.pose == at_images  # what ticks map the flies with
        assert pipeline.published.pose != readings[-1].pose
    finally:
        pipeline.close()


def test_the_flies_snapshot_is_in_base_link_at_the_snapshots_time(monkeypatch):
    # scored where the images were taken (50 ms), published where the robot is at the
    # snapshot's stamp (150 ms: the newest odometry, 140 ms, carried on for 10 ms); a
    # cloud at the newest reading's pose but stamped 150 ms lags the turn by 5 mrad
    from flylog.geometry import relative
    from flylog.geometry.proprioception import moved_by_odometry
    from flylog.io import encode

    sent = []  # the clouds as they go to the /flies encoder
    point_cloud = encode.point_cloud

    def spy(xyz, *args, **kwargs):
        sent.append(np.array(xyz))
        return point_cloud(xyz, *args, **kwargs)

    monkeypatch.setattr(encode, "point_cloud", spy)

    rig = StereoRig(width=64, height=48, focal_px=50.0)
    pipeline = FlyPipeline(
        ReplayConfig(seed=0), rig, Pose2D(0.0, 0.0, 3.0), (5.0, 0.0), lambda *a: None
    )
    try:
        readings = _turning(8)
        for r in list(readings)[:4]:
            pipeline.deliver(r)
        images = np.full((48, 64, 3), 128, dtype=np.uint8)
        pipeline.deliver(StereoPair(50 * MS, images, images))
        for r in list(readings)[4:]:
            pipeline.deliver(r)
        pipeline.generation(False)
        pipeline.publish(150 * MS)
        scored = pipeline.engine.population.xyz.copy()
        pipeline.tick("snapshot", 150 * MS)
        pipeline.flush()
    finally:
        pipeline.close()
    assert len(sent) == 1
    at_snapshot = pose_at(readings, 150 * MS)
    assert at_snapshot.theta == pytest.approx(readings[-1].pose.theta + 0.5 * 0.010)
    expected = moved_by_odometry(scored, relative(pose_at(readings, 50 * MS), at_snapshot))
    np.testing.assert_allclose(sent[0], expected, rtol=0, atol=1e-12)
    assert not np.allclose(sent[0], scored, atol=1e-3)  # 0.05 rad of turn between


def _readout_of_pair(row_period_ns: float, stamp_ns: int, delivered: int) -> Pose2D:
    """The readout the engine receives with a pair stamped ``stamp_ns``, when ``delivered``
    odometry readings (50 Hz, turning at 0.5 rad/s) came before it."""
    rig = StereoRig(width=64, height=48, focal_px=50.0)
    pipeline = FlyPipeline(
        ReplayConfig(seed=0),
        rig,
        Pose2D(0.0, 0.0, 3.0),
        (5.0, 0.0),
        lambda *a: None,
        row_period_ns=row_period_ns,
    )
    try:
        for r in list(_turning(delivered)):
            pipeline.deliver(r)
        images = np.full((48, 64, 3), 128, dtype=np.uint8)
        pipeline.deliver(StereoPair(stamp_ns, images, images))
        pipeline.generation(False)
        pipeline.publish(stamp_ns + 10 * MS)
        pair = pipeline.published.pair
        assert pair is not None
        return pair.readout
    finally:
        pipeline.close()


def test_each_pair_carries_the_robots_motion_over_its_readout_from_the_odometry():
    # 48 rows of 130 µs: a readout of 6.24 ms, 3.12 mrad of the 0.5 rad/s turn
    period = 130_000.0
    turn = 0.5 * 48 * period * 1e-9
    # odometry past the readout's end (60 ms ≥ 50 + 6.24 ms): stamp to stamp + readout
    inside = _readout_of_pair(period, 50 * MS, 4)
    assert (inside.x, inside.y) == pytest.approx((0.0, 0.0), abs=1e-12)
    assert inside.theta == pytest.approx(turn, rel=1e-9)
    # the newest reading (60 ms) before the readout's end: the same span ending there
    late = _readout_of_pair(period, 58 * MS, 4)
    assert late.theta == pytest.approx(turn, rel=1e-9)
    # a readout of 40 ms (834 µs a row) before the newest reading: measured, not carried on
    # for one reading interval only (which would give 20 ms of it)
    long = _readout_of_pair(834_000.0, 30 * MS, 4)
    assert long.theta == pytest.approx(0.5 * 48 * 834_000e-9, rel=1e-9)
    # a global shutter: every row at the stamp
    assert _readout_of_pair(0.0, 50 * MS, 4) == Pose2D(0.0, 0.0, 0.0)
