import dataclasses
import math

import numpy as np
import pytest

from flylog.fly import Backend, EngineConfig, FlyEngine
from flylog.fly.operators import newcomer_constants
from flylog.fly.scouts import (
    Scouting,
    best_candidates_into,
    best_candidates_numpy,
    entering_strip,
    scout_candidates_into,
    scout_candidates_numpy,
)
from flylog.geometry import Pose2D, StereoRig
from flylog.geometry.rolling import row_motion, seen_at_rows
from tests.fly.analytic import render, room, true_depth_at

RIG = StereoRig(width=320, height=240, focal_px=250.0)
MARGIN = 3
K = newcomer_constants(RIG, 0.5, 20.0, MARGIN)
FB = RIG.focal_px * RIG.baseline


def candidates_numba(rng, k, strip, n, n_depths, rm=None):
    out = np.empty((n * n_depths, 3))
    rolling = rm is not None
    rm = np.zeros(3) if rm is None else rm
    scout_candidates_into(rng, k, strip[0], strip[1], strip[2], n_depths, rm, rolling, out)
    return out


def best_numba(candidates, fitness, n_depths):
    out = np.empty((len(fitness) // n_depths, 3))
    best_candidates_into(candidates, fitness, n_depths, out)
    return out


CANDIDATES = [scout_candidates_numpy, candidates_numba]
BEST = [best_candidates_numpy, best_numba]


def test_turning_right_the_strip_is_the_left_images_right_edge():
    yaw = -math.radians(2.0)
    c0, c1, in_right = entering_strip(RIG, yaw, MARGIN)
    edge = math.atan2(RIG.width - 1 - RIG.cx, RIG.focal_px)
    assert not in_right and c1 == RIG.width - 1 - MARGIN
    # 2° inside the edge bearing: 250·(tan 32.54° − tan 30.54°) ≈ 12.0 px
    assert c0 == pytest.approx(RIG.cx + RIG.focal_px * math.tan(edge + yaw))
    assert RIG.width - 1 - c0 == pytest.approx(12.0, abs=0.05)


def test_turning_left_the_strip_is_the_right_images_left_edge():
    c0, c1, in_right = entering_strip(RIG, math.radians(2.0), MARGIN)
    assert in_right and c0 == MARGIN
    edge = math.atan2(RIG.cx, RIG.focal_px)
    assert c1 == pytest.approx(RIG.cx - RIG.focal_px * math.tan(edge - math.radians(2.0)))
    # a tiny turn still gives a strip of min_width px; no turn gives none
    tiny = entering_strip(RIG, 1e-6, MARGIN, min_width=2.0)
    assert tiny[:2] == (MARGIN, MARGIN + 2.0)
    assert entering_strip(RIG, 0.0, MARGIN)[1] < entering_strip(RIG, 0.0, MARGIN)[0]


@pytest.mark.parametrize("make", CANDIDATES)
@pytest.mark.parametrize("yaw", [-0.05, 0.05])
def test_candidates_lie_in_the_strip_one_per_disparity_stratum(make, yaw):
    strip = entering_strip(RIG, yaw, MARGIN)
    n, depths = 200, 8
    xyz = make(np.random.default_rng(1), K, strip, n, depths)
    u_left, u_right, v, depth = RIG.project(xyz)
    column = u_right if strip[2] else u_left
    assert np.all((column >= strip[0] - 1e-9) & (column <= strip[1] + 1e-9))
    assert np.all((v >= MARGIN) & (v <= RIG.height - 1 - MARGIN))
    for u in (u_left, u_right):  # both projections inside the image
        assert np.all((u >= MARGIN - 1e-6) & (u <= RIG.width - 1 - MARGIN + 1e-6))
    # a scout's K candidates share its pixel in the strip and climb its disparity range
    disparity = (u_left - u_right).reshape(n, depths)
    assert np.all(np.diff(disparity, axis=1) > 0)
    assert np.ptp(column.reshape(n, depths), axis=1).max() < 1e-6
    assert disparity.min() >= FB / 20.0 - 1e-9 and disparity.max() <= FB / 0.5 + 1e-9
    assert np.all(depth > 0)


def test_candidate_implementations_draw_the_same_flies_and_numbers():
    for yaw in (-0.03, 0.03):
        strip = entering_strip(RIG, yaw, MARGIN)
        a, b = np.random.default_rng(5), np.random.default_rng(5)
        np.testing.assert_array_equal(
            scout_candidates_numpy(a, K, strip, 37, 6), candidates_numba(b, K, strip, 37, 6)
        )
        assert a.random() == b.random()


@pytest.mark.parametrize("best", BEST)
def test_best_candidate_is_the_fittest_first_of_equals(best):
    candidates = np.arange(18, dtype=float).reshape(6, 3)
    fitness = np.array([0.1, 0.7, 0.7, -1.0, -1.0, -1.0])
    out = best(candidates, fitness, 3)
    np.testing.assert_array_equal(out, candidates[[1, 3]])


# --- in the engine --------------------------------------------------------------------------

PANEL = ((2.0, -1.6, 0.0), (2.1, -0.2, 1.2))  # in view, right of the image centre


@pytest.fixture(scope="module")
def panel_frame():
    return render(room(PANEL), RIG)


def turned_engine(config, frame, yaw, *, seed=0, generations=1):
    engine = FlyEngine(config, RIG, np.random.default_rng(seed))
    engine.apply_motion(Pose2D(0.0, 0.0, yaw))
    engine.set_images(frame[0])
    stats = [engine.step() for _ in range(generations)]
    return engine, stats


def test_scouts_are_charged_and_placed_only_while_turning(panel_frame):
    cfg = EngineConfig(flies=1000, scouting=True, scout_fraction=0.5, scout_candidates=8)
    n_scouts = round(0.5 * cfg.immigrants)
    _, s0 = turned_engine(cfg, panel_frame, 0.0)
    turning, s1 = turned_engine(cfg, panel_frame, -0.03)
    _, s2 = turned_engine(dataclasses.replace(cfg, scouting=False), panel_frame, -0.03)
    assert s1[0].evaluations == s0[0].evaluations + 8 * n_scouts == s2[0].evaluations + 80
    # driving forward: nothing enters at an edge, nobody scouts
    ahead = FlyEngine(cfg, RIG, np.random.default_rng(0))
    ahead.apply_motion(Pose2D(0.1, 0.0, 0.0))
    ahead.set_images(panel_frame[0])
    assert ahead.step().evaluations == s0[0].evaluations
    c0, c1, _ = entering_strip(RIG, -0.03, cfg.window // 2)
    u_left, _, _, _ = RIG.project(turning.population.xyz[-n_scouts:])
    assert np.all((u_left >= c0 - 1e-9) & (u_left <= c1 + 1e-9))


def test_a_generation_never_makes_more_evaluations_than_the_config_bounds(panel_frame):
    """Replay's clock relies on EngineConfig.max_evaluations (it decides from it when a
    published population may be dropped): every scout scouting, all flies stale."""
    cfg = EngineConfig(
        flies=400, scouting=True, scout_fraction=1.0, scout_candidates=64, sonar_immigration=False
    )
    _, stats = turned_engine(cfg, panel_frame, -0.03)
    assert stats[0].evaluations == cfg.max_evaluations  # the bound is reached, not exceeded


def test_scouts_find_the_depth_of_what_enters_the_view(panel_frame):
    # Turning right by 0.06 rad, the right edge is new: there the panel is at 2 m (the
    # floor below it). Best of 16 depths, a scout is on the surface (within 5 %) far more
    # often than a uniform immigrant (measured: 0.39 against 0.03).
    _, depth = panel_frame
    cfg = EngineConfig(
        flies=2000, scouting=True, immigration_fraction=0.1, scout_fraction=1.0, scout_candidates=16
    )

    def on_surface(config):
        engine, _ = turned_engine(config, panel_frame, -0.06)
        immigrants = engine.population.xyz[-cfg.immigrants :]
        truth = true_depth_at(depth, RIG, immigrants)
        return np.mean(np.abs(immigrants[:, 0] - RIG.mount_x - truth) <= 0.05 * truth)

    scouts, uniform = on_surface(cfg), on_surface(dataclasses.replace(cfg, scouting=False))
    assert scouts >= 0.3 and scouts >= 5 * uniform


@pytest.mark.parametrize("yaw", [-0.03, 0.03])
def test_numba_and_numpy_backends_give_the_same_population_while_turning(panel_frame, yaw):
    cfg = EngineConfig(flies=800, scouting=True)
    a, _ = turned_engine(cfg, panel_frame, yaw, seed=4, generations=3)
    b, _ = turned_engine(
        dataclasses.replace(cfg, backend=Backend.NUMPY), panel_frame, yaw, seed=4, generations=3
    )
    for field in ("xyz", "fitness", "vision", "stale", "stamp_ns", "age"):
        np.testing.assert_array_equal(
            getattr(a.population, field), getattr(b.population, field), err_msg=field
        )
    c, _ = turned_engine(cfg, panel_frame, yaw, seed=4, generations=3)
    np.testing.assert_array_equal(a.population.xyz, c.population.xyz)


def test_the_strip_spans_the_turn_of_the_last_image_intervals():
    scouts = Scouting(
        EngineConfig(scouting=True, scout_strip_frames=2, scout_min_shift=0.5), RIG, MARGIN
    )
    assert scouts.count(100, 0) == 0  # no images yet
    for _ in range(2):
        scouts.turned(-0.004)
        scouts.turned(-0.006)
        scouts.new_images()
    assert scouts.strip[:2] == pytest.approx(entering_strip(RIG, -0.02, MARGIN)[:2])
    assert scouts.count(100, 70) == 15 and scouts.count(100, 20) == 40  # half the uniform
    # one interval without a turn: the strip covers the other one; two: no strip
    scouts.new_images()
    assert scouts.strip[:2] == pytest.approx(entering_strip(RIG, -0.01, MARGIN)[:2])
    scouts.new_images()
    assert scouts.strip[1] < scouts.strip[0] and scouts.count(100, 0) == 0
    # a turn too slow to move the edge by scout_min_shift px per frame: no strip either
    scouts.turned(-0.001)  # 0.35 px at the edge, over 2 frames
    scouts.new_images()
    assert scouts.count(100, 0) == 0


def test_candidates_under_a_rolling_shutter_are_their_rows_points_at_the_stamp():
    # A scout drawn at (u, v) and a depth is seen at row v's time: brought to the stamp by
    # row v's motion, it projects back to (u, v) once moved by that motion's inverse.
    rm = row_motion(Pose2D(0.004, -0.002, 0.0156), RIG.height)
    for yaw in (-0.03, 0.03):
        strip = entering_strip(RIG, yaw, MARGIN)
        a, b = np.random.default_rng(5), np.random.default_rng(5)
        rolling = scout_candidates_numpy(a, K, strip, 37, 6, rm)
        np.testing.assert_array_equal(rolling, candidates_numba(b, K, strip, 37, 6, rm))
        still = scout_candidates_numpy(np.random.default_rng(5), K, strip, 37, 6)
        v = RIG.project(still)[2]
        assert np.abs(rolling - still).max() > 1e-3  # moved: 16 mrad over the readout
        back = RIG.project(seen_at_rows(rolling, rm, v))
        for got, want in zip(back, RIG.project(still), strict=True):
            np.testing.assert_allclose(got, want, atol=1e-4)
