"""Distinctness along the epipolar line: known disparities, a horizontal-stripe image that
matches at every depth, the numba path against the numpy reference, and the obstacle rule."""

import math

import numpy as np
import pytest

from flylog.errors import ConfigError
from flylog.fly.config import EngineConfig, Gradient
from flylog.fly.distinct import NO_RIVAL, at_infinity, distinctness, shifted_along_epipolar
from flylog.fly.obstacles import ObstacleFlies
from flylog.geometry import StereoRig
from flylog.sensors import StereoPair

RIG = StereoRig(width=96, height=64, focal_px=80.0, baseline=0.12)
SHIFTS = (-4, -2, 2, 4)
TRUE_DISPARITY = 8  # px: depth = 80 · 0.12 / 8 = 1.2 m
WINDOW, GUARD = 7, 1.0


def _textured_pair(seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """A random RGB texture; the right image is the left moved TRUE_DISPARITY px left
    (every pixel at disparity exactly TRUE_DISPARITY)."""
    rng = np.random.default_rng(seed)
    wide = rng.integers(0, 256, (RIG.height, RIG.width + TRUE_DISPARITY, 3), dtype=np.uint8)
    return np.ascontiguousarray(wide[:, : RIG.width]), np.ascontiguousarray(
        wide[:, TRUE_DISPARITY:]
    )


def _flies_at(disparity: float, n: int = 40, seed: int = 0) -> np.ndarray:
    """Points in the middle of the image at ``disparity`` px."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(20, RIG.width - 20, n)
    v = rng.uniform(12, RIG.height - 12, n)
    depth = np.full(n, RIG.focal_px * RIG.baseline / disparity)
    return RIG.backproject(u, v, depth)


def test_shifted_points_keep_the_left_pixel_and_move_the_disparity():
    xyz = _flies_at(TRUE_DISPARITY)
    shifted, valid = shifted_along_epipolar(xyz, RIG, (-9, -3, 5))
    u0, r0, v0, _ = RIG.project(xyz)
    for k, s in enumerate((-9, -3, 5)):
        u, r, v, _ = RIG.project(shifted[k])
        assert valid[k].all() == (s > -TRUE_DISPARITY)
        ok = valid[k]
        np.testing.assert_allclose(u[ok], u0[ok], atol=1e-9)
        np.testing.assert_allclose(v[ok], v0[ok], atol=1e-9)
        np.testing.assert_allclose((u - r)[ok], (u0 - r0)[ok] + s, atol=1e-9)
        np.testing.assert_array_equal(shifted[k][~ok], xyz[~ok])  # left where it was


def test_all_shifts_at_once_equal_one_shift_at_a_time_bit_for_bit():
    rng = np.random.default_rng(3)
    xyz = RIG.backproject(
        rng.uniform(-20, RIG.width + 20, 500),
        rng.uniform(0, RIG.height, 500),
        rng.uniform(0.3, 30.0, 500),
    )
    xyz[::17, 0] = RIG.mount_x - 0.2  # behind the cameras
    shifts = (-40, -4, -2, 2, 4)
    shifted, valid = shifted_along_epipolar(xyz, RIG, shifts)
    u_left, u_right, v, depth = RIG.project(xyz)
    fb = RIG.focal_px * RIG.baseline
    for k, s in enumerate(shifts):  # the reference: one shift at a time
        d = (u_left - u_right) + s
        ok = (d > 0) & (depth > 0)
        one = np.where(ok[:, None], RIG.backproject(u_left, v, fb / np.where(ok, d, 1.0)), xyz)
        np.testing.assert_array_equal(valid[k], ok)
        np.testing.assert_array_equal(shifted[k], one)
    assert not valid.all() and valid.any()


@pytest.mark.parametrize("use_numba", [False, True])
def test_true_depth_is_distinct_and_a_wrong_one_is_not(use_numba):
    left, right = _textured_pair()
    true = distinctness(
        left, right, _flies_at(TRUE_DISPARITY), RIG, WINDOW, GUARD, SHIFTS, use_numba=use_numba
    )
    # 2 px off: the true disparity is one of its rivals
    wrong = distinctness(
        left, right, _flies_at(TRUE_DISPARITY + 2), RIG, WINDOW, GUARD, SHIFTS, use_numba=use_numba
    )
    assert true.min() > 10.0  # a perfect match (ZSSD 0) against random-texture rivals
    assert wrong.max() < 0.1


@pytest.mark.parametrize("gradient", list(Gradient))
def test_horizontal_stripes_match_at_every_depth(gradient):
    """Rows vary, columns do not: every disparity matches as well as any other."""
    rows = np.random.default_rng(1).integers(0, 256, (RIG.height, 1, 3), dtype=np.uint8)
    image = np.ascontiguousarray(np.broadcast_to(rows, (RIG.height, RIG.width, 3)))
    got = distinctness(
        image, image, _flies_at(TRUE_DISPARITY), RIG, WINDOW, GUARD, SHIFTS, gradient=gradient
    )
    if gradient is Gradient.NORM:
        np.testing.assert_array_equal(got, 1.0)  # G > 0, the same ZSSD (0) at every shift
    else:
        np.testing.assert_array_equal(got, 0.0)  # no horizontal gradient: fitness 0


def test_numba_and_numpy_agree_bit_for_bit():
    left, right = _textured_pair(seed=9)
    rng = np.random.default_rng(2)
    xyz = np.concatenate([_flies_at(d, 30, seed=i) for i, d in enumerate(rng.uniform(1, 30, 8))])
    xyz[:5, 0] = -1.0  # behind the cameras: fitness invalid, distinctness 0
    for gradient in Gradient:
        a = distinctness(left, right, xyz, RIG, WINDOW, GUARD, SHIFTS, gradient=gradient)
        b = distinctness(
            left, right, xyz, RIG, WINDOW, GUARD, SHIFTS, gradient=gradient, use_numba=False
        )
        np.testing.assert_array_equal(a, b)
        assert (a[:5] == 0.0).all()


def _striped_sky(period: int) -> np.ndarray:
    """Columns repeat every ``period`` px, rows vary (a separable pattern, like the
    simulator's sky); both cameras see it at disparity 0 (the same image)."""
    rng = np.random.default_rng(5)
    cols = rng.integers(0, 256, period)[np.arange(RIG.width) % period]
    rows = rng.uniform(0.5, 1.0, RIG.height)
    grey = (rows[:, None] * cols[None, :]).astype(np.uint8)
    return np.ascontiguousarray(np.repeat(grey[:, :, None], 3, axis=2))


@pytest.mark.parametrize("use_numba", [False, True])
def test_a_false_match_on_a_striped_sky_loses_to_the_rival_at_infinity(use_numba):
    sky = _striped_sky(period=TRUE_DISPARITY)
    phantom = _flies_at(TRUE_DISPARITY)  # one period off: a perfect false match
    args = (sky, sky, phantom, RIG, WINDOW, GUARD, SHIFTS)
    near_only = distinctness(*args, use_numba=use_numba)
    with_infinity = distinctness(*args, use_numba=use_numba, infinity=True)
    assert near_only.min() > 10.0  # its ±2, ±4 px neighbours do not match: it passes
    np.testing.assert_array_equal(with_infinity, 1.0)  # infinity matches as well
    # a real surface at that disparity is not touched: infinity is a random mismatch there
    left, right = _textured_pair()
    real = distinctness(
        left, right, phantom, RIG, WINDOW, GUARD, SHIFTS, infinity=True, use_numba=use_numba
    )
    assert real.min() > 10.0


def test_the_rival_at_infinity_keeps_the_left_pixel_at_disparity_zero():
    xyz = _flies_at(TRUE_DISPARITY)
    far, valid = at_infinity(xyz, RIG)
    u, r, v, _ = RIG.project(far)
    u0, _, v0, _ = RIG.project(xyz)
    assert valid.all()
    np.testing.assert_array_equal(np.floor(u + 0.5), np.floor(u0 + 0.5))
    np.testing.assert_array_equal(np.floor(r + 0.5), np.floor(u0 + 0.5))  # same column
    np.testing.assert_array_equal(np.floor(v + 0.5), np.floor(v0 + 0.5))


def test_a_fly_without_rivals_has_no_rival_value():
    left, right = _textured_pair()
    xyz = _flies_at(1.5, 5)  # every negative shift takes the disparity to ≤ 0
    got = distinctness(left, right, xyz, RIG, WINDOW, GUARD, (-4, -2))
    assert (got == NO_RIVAL).all() and math.isinf(NO_RIVAL)


def test_rule_measures_only_its_candidates_and_drops_indistinct_flies():
    left, right = _textured_pair()
    xyz = np.concatenate([_flies_at(TRUE_DISPARITY, 10), _flies_at(TRUE_DISPARITY + 2, 10)])
    fitness = np.full(20, 2.0)
    fitness[[0, 10]] = 0.1  # below the quantile: not candidates, not measured
    age = np.full(20, 5)
    rule = ObstacleFlies(quantile=0.1, min_age=3, min_distinctness=1.5)
    pair = StereoPair(0, left, right)
    candidates = rule.candidates(xyz, fitness, age)
    # the fly itself, its four shifted rivals and the rival at infinity
    assert rule.distinct_evaluations(candidates) == 18 * (1 + 4 + 1)
    no_infinity = ObstacleFlies(
        quantile=0.1, min_age=3, min_distinctness=1.5, distinct_at_infinity=False
    )
    assert no_infinity.distinct_evaluations(candidates) == 18 * (1 + 4)
    engine = EngineConfig(window=WINDOW, guard=GUARD)
    distinct = rule.distinct_of(xyz, candidates, pair, RIG, engine)
    assert np.isnan(distinct[[0, 10]]).all() and not np.isnan(np.delete(distinct, [0, 10])).any()
    keep = rule.mask(xyz, fitness, age, distinct)
    assert keep.tolist() == [False] + [True] * 9 + [False] * 10
    assert rule.keep(candidates, distinct).tolist() == keep.tolist()
    with pytest.raises(ValueError, match="needs each fly's distinctness"):
        rule.mask(xyz, fitness, age)
    # the paper's rule (off) measures nothing and needs nothing
    off = ObstacleFlies(quantile=0.1, min_age=3, min_distinctness=0.0)
    assert off.distinct_of(xyz, candidates, pair, RIG, EngineConfig()) is None
    assert off.distinct_evaluations(candidates) == 0
    assert off.mask(xyz, fitness, age).sum() == 18


def test_rule_rejects_a_zero_shift():
    with pytest.raises(ConfigError, match="distinct_shifts"):
        ObstacleFlies(min_distinctness=1.5, distinct_shifts=(0, 2))
