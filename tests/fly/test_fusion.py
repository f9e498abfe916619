import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flylog.fly.fusion import (
    fired_sonars,
    sonar_confirmations,
    sonar_confirmations_numba,
    sonar_confirmations_numpy,
    sonar_fuse_into,
    sonar_fused,
    sonar_fused_numba,
    sonar_immigrants,
)
from flylog.geometry import Pose2D, StereoRig, compose
from flylog.geometry.proprioception import moved_by_odometry
from flylog.sensors import SonarConfig, SonarReading

RIG = StereoRig()
MOUNTS = SonarConfig().mounts()


def reading(ranges) -> SonarReading:
    return SonarReading(0, np.asarray(ranges, float), MOUNTS, math.radians(15.0), 3.0)


def test_confirmation_known_geometry():
    # Sonar 3 looks 10° left; a fly 1.0 m along its axis, with range 1.0 m measured.
    mx, my, yaw = MOUNTS[3]
    r = reading([np.nan, np.nan, np.nan, 1.0, np.nan, np.nan])

    def at(dist, bearing, z=0.2):
        return [mx + dist * math.cos(yaw + bearing), my + dist * math.sin(yaw + bearing), z]

    xyz = np.array(
        [
            at(1.0, 0.0),  # on the axis, right range
            at(1.05, math.radians(7.0)),  # in the cone, within tolerance
            at(1.0, math.radians(8.0)),  # outside the 7.5° half angle
            at(1.3, 0.0),  # range too far off
            at(1.0, 0.0, z=1.5),  # the cone is 2-D: height does not matter
        ]
    )
    for use_numba in (True, False):
        got = sonar_confirmations(xyz, r, 0.1, use_numba=use_numba)
        assert list(got) == [1, 1, 0, 0, 1]
    unfired = reading([np.nan] * 6)
    assert sonar_confirmations(xyz, unfired, 0.1).sum() == 0


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_confirmation_kernel_equals_reference(seed):
    rng = np.random.default_rng(seed)
    ranges = np.where(rng.random(6) < 0.6, rng.uniform(0.2, 3.0, 6), np.nan)
    xyz = np.column_stack([rng.uniform(-1, 3.5, 500), rng.uniform(-3, 3, 500), rng.random(500)])
    sonars = fired_sonars(reading(ranges))
    cos_half = math.cos(math.radians(7.5))
    np.testing.assert_array_equal(
        sonar_confirmations_numba(xyz, sonars, cos_half, 0.15),
        sonar_confirmations_numpy(xyz, sonars, cos_half, 0.15),
    )


@pytest.mark.parametrize("use_numba", [True, False])
def test_fusion_multiplies_only_positive_confirmed_fitness(use_numba):
    mx, my, yaw = MOUNTS[0]
    on = [mx + math.cos(yaw), my + math.sin(yaw), 0.3]
    xyz = np.array([on, on, [5.0, 0.0, 0.3]])
    vision = np.array([2.0, -1.0, 2.0])
    got = sonar_fused(
        vision, xyz, reading([1.0] + [np.nan] * 5), bonus=0.5, tolerance=0.1, use_numba=use_numba
    )
    assert list(got) == [3.0, -1.0, 2.0]


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(0.0, 2.0))
def test_fused_kernel_equals_reference(seed, bonus):
    rng = np.random.default_rng(seed)
    # Sonars facing each other across a small area, so flies are confirmed 0, 1 or 2 times.
    ranges = np.where(rng.random(6) < 0.8, rng.uniform(0.2, 1.5, 6), np.nan)
    xyz = np.column_stack([rng.uniform(-0.5, 1.5, 400), rng.uniform(-1, 1, 400), rng.random(400)])
    vision = np.where(rng.random(400) < 0.2, -1.0, rng.exponential(size=400))
    r = reading(ranges)
    expected = sonar_fused(vision, xyz, r, bonus=bonus, tolerance=0.3, use_numba=False)
    sonars = fired_sonars(r)
    got = sonar_fused_numba(vision, xyz, sonars, math.cos(r.half_cone), 0.3, bonus)
    np.testing.assert_array_equal(got, expected)


def test_sonar_immigrants_on_arc_in_cone_and_in_view():
    rng = np.random.default_rng(0)
    r = reading([np.nan, np.nan, 1.2, 2.0, np.nan, np.nan])
    xyz = sonar_immigrants(rng, r, 500, RIG, tolerance=0.1, margin=3)
    assert len(xyz) == 500
    counts = sonar_confirmations(xyz, r, 0.1 + 1e-9)
    assert (counts >= 1).all()
    u, ur, v, depth = RIG.project(xyz)
    assert (depth > 0).all() and (u >= 3).all() and (ur >= 3).all()
    assert (u <= RIG.width - 4).all() and (v >= 3).all() and (v <= RIG.height - 4).all()
    assert xyz[:, 2].min() >= 0 and xyz[:, 2].max() <= RIG.mount_height
    # Both fired sonars get immigrants.
    one_fired = reading([np.nan, np.nan, 1.2, np.nan, np.nan, np.nan])
    assert set(np.unique(sonar_confirmations(xyz[:, :], one_fired, 0.1 + 1e-9))) == {0, 1}


def test_sonar_immigrants_none_when_arc_out_of_view():
    rng = np.random.default_rng(0)
    # Sonar 0 looks 50° right, outside the cameras' ±32.6° field of view.
    xyz = sonar_immigrants(rng, reading([1.0] + [np.nan] * 5), 50, RIG, tolerance=0.1, margin=3)
    assert len(xyz) == 0


def test_proprioception_moves_flies_by_inverse_motion():
    world = np.array([[3.0, 1.0, 0.4], [1.0, -2.0, 0.1]])
    start = Pose2D(0.5, -0.2, 0.3)
    step = Pose2D(0.2, 0.05, math.radians(-1.0))
    end = compose(start, step)

    def in_robot(pose, pts):
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        d = pts[:, :2] - [pose.x, pose.y]
        return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1], pts[:, 2]])

    moved = moved_by_odometry(in_robot(start, world), step)
    np.testing.assert_allclose(moved, in_robot(end, world), atol=1e-12)


def test_forward_motion_brings_flies_closer():
    got = moved_by_odometry(np.array([[3.0, 0.5, 0.2]]), Pose2D(1.0, 0.0, 0.0))
    assert got[0] == pytest.approx([2.0, 0.5, 0.2])


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 120), st.integers(1, 8))
def test_sonar_immigrant_kernel_equals_reference(seed, n, tries):
    rng = np.random.default_rng(seed)
    ranges = np.where(rng.random(6) < 0.7, rng.uniform(0.3, 3.0, 6), np.nan)
    ranges[rng.integers(0, 6)] = rng.uniform(0.3, 3.0)  # at least one fired
    r = reading(ranges)
    numpy_rng, numba_rng = np.random.default_rng(seed), np.random.default_rng(seed)
    expected = sonar_immigrants(numpy_rng, r, n, RIG, tolerance=0.1, margin=3, tries=tries)
    got = sonar_immigrants(
        numba_rng, r, n, RIG, tolerance=0.1, margin=3, tries=tries, use_numba=True
    )
    np.testing.assert_array_equal(got, expected)
    # both drew the same numbers: the streams go on alike
    assert numpy_rng.random() == numba_rng.random()


def test_sonar_immigrants_draw_whole_chunks_of_candidates():
    # A sonar whose arc is always in view: the first chunk of n candidates gives all n flies,
    # and exactly 4 numbers per candidate are drawn.
    r = reading([np.nan, np.nan, 1.5, np.nan, np.nan, np.nan])
    for use_numba in (True, False):
        rng, twin = np.random.default_rng(5), np.random.default_rng(5)
        xyz = sonar_immigrants(rng, r, 30, RIG, tolerance=0.1, margin=3, use_numba=use_numba)
        assert len(xyz) == 30
        twin.random(4 * 30)
        assert rng.random() == twin.random()


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(1e-3, 0.3))
def test_fused_kernel_equals_reference_at_the_range_window_edges(seed, tolerance):
    # Flies exactly at (and a rounding error from) r ± tolerance of each sonar, in its cone:
    # the vectorised kernel must decide them as the reference does. A window of width 0
    # (tolerance 0) may confirm no fly at all, so the draws start at 1 mm.
    rng = np.random.default_rng(seed)
    ranges = np.where(rng.random(6) < 0.8, rng.uniform(0.1, 3.0, 6), np.nan)
    ranges[rng.integers(0, 6)] = rng.uniform(0.1, 3.0)
    r = reading(ranges)
    flies = []
    for s in np.flatnonzero(r.fired):
        mx, my, yaw = MOUNTS[s]
        for d in (ranges[s] - tolerance, ranges[s] + tolerance):
            for eps in (-1e-12, 0.0, 1e-12):
                b = yaw + rng.uniform(-r.half_cone, r.half_cone)
                flies.append([mx + (d + eps) * math.cos(b), my + (d + eps) * math.sin(b), 0.2])
    xyz = np.array(flies)
    vision = np.ones(len(xyz))
    expected = sonar_fused(vision, xyz, r, bonus=0.5, tolerance=tolerance, use_numba=False)
    got = sonar_fused(vision, xyz, r, bonus=0.5, tolerance=tolerance, use_numba=True)
    np.testing.assert_array_equal(got, expected)
    assert (expected > 1.0).any()  # some flies are confirmed: the test can fail


def test_fuse_into_writes_only_the_given_flies():
    rng = np.random.default_rng(3)
    ranges = [np.nan, 0.8, 1.0, 1.2, np.nan, np.nan]
    xyz = np.column_stack([rng.uniform(0, 1.5, 300), rng.uniform(-1, 1, 300), rng.random(300)])
    vision = np.where(rng.random(300) < 0.2, -1.0, rng.exponential(size=300))
    r = reading(ranges)
    expected = sonar_fused(vision, xyz, r, bonus=0.5, tolerance=0.3, use_numba=False)
    assert (expected != vision).sum() > 10  # some flies confirmed: the test can fail
    index = np.flatnonzero(rng.random(300) < 0.5)
    out = np.full(300, 7.0)
    sonar_fuse_into(vision, xyz, fired_sonars(r), math.cos(r.half_cone), 0.3, 0.5, index, out)
    np.testing.assert_array_equal(out[index], expected[index])
    untouched = np.ones(300, dtype=bool)
    untouched[index] = False
    assert (out[untouched] == 7.0).all()


def test_move_in_place_equals_moved_bit_for_bit():
    from flylog.geometry.proprioception import move_by_odometry

    rng = np.random.default_rng(3)
    xyz = rng.uniform(-5, 5, (1000, 3))
    for step in (Pose2D(0.02, -0.001, 0.003), Pose2D(-1.5, 2.0, -3.1), Pose2D(0.0, 0.0, 0.0)):
        expected = moved_by_odometry(xyz, step)
        move_by_odometry(xyz, step)
        np.testing.assert_array_equal(xyz, expected)


@pytest.mark.parametrize("with_sonar", [False, True])
def test_score_kernel_equals_fitness_then_fusion(with_sonar):
    from flylog.fly.bundles import Flies, Fusion
    from flylog.fly.fitness import INVALID_FITNESS, fitness_numpy, images_of
    from flylog.fly.fusion import score_into
    from flylog.fly.measures import ZSSD
    from flylog.fly.operators import random_flies

    rng = np.random.default_rng(4)
    rig = StereoRig(width=64, height=48, focal_px=50.0)
    left = rng.integers(0, 256, (48, 64, 3), dtype=np.uint8)
    right = np.roll(left, -3, axis=1)
    xyz = random_flies(rng, rig, 400, d_min=0.5, d_max=5.0, margin=3)
    # flies on the sonar arcs: some are confirmed
    r = reading([np.nan, 1.0, np.nan, 1.2, np.nan, np.nan])
    xyz[:100, :2] = sonar_immigrants(rng, r, 100, RIG, tolerance=0.1, margin=3)[:, :2][
        rng.integers(0, 10, 100)
    ]
    index = np.arange(50, 400, 2)
    fuse = np.arange(400)
    vision = np.full(400, INVALID_FITNESS)
    vision[1::2] = rng.random(200)  # evaluated before
    stale, stamp = np.ones(400, dtype=bool), np.full(400, -1, dtype=np.int64)
    fitness = np.full(400, 9.0)
    expected_vision = vision.copy()
    expected_vision[index] = fitness_numpy(left, right, xyz[index], rig, 7, 1.0)
    sonars = fired_sonars(r) if with_sonar else np.empty((0, 5))
    if with_sonar:
        expected = sonar_fused(expected_vision, xyz, r, bonus=0.5, tolerance=0.1, use_numba=False)
        assert (expected != expected_vision).sum() > 3  # some flies confirmed
    else:
        expected = expected_vision
    im = images_of(left, right, rig, 7, 1.0, stamp_ns=42)
    fu = Fusion(sonars=sonars, cos_half_cone=math.cos(r.half_cone), tolerance=0.1, bonus=0.5)
    age = np.zeros(400, dtype=np.int32)
    score_into(im, ZSSD, fu, Flies(xyz, fitness, vision, stale, stamp, age), index, fuse)
    np.testing.assert_array_equal(vision, expected_vision)
    np.testing.assert_array_equal(fitness, expected)
    assert not stale[index].any() and (stamp[index] == 42).all()
    assert stale[1:50:2].all() and (stamp[1:50:2] == -1).all()
