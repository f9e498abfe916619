"""The compiled engine's one call per generation (flylog.fly.generation)."""

import dataclasses

import numpy as np
import pytest

import flylog.fly.numba_backend as engine_module
from flylog.fly import Backend, EngineConfig, FlyEngine
from flylog.fly.fitness import rig_constants
from flylog.fly.generation import rows_order_into
from flylog.geometry import Pose2D, StereoRig
from tests.fly.analytic import default_sonar_reading, render, room
from tests.fly.reference_generation import rows_order_numpy

SMALL = StereoRig(width=320, height=240, focal_px=250.0)


@pytest.mark.parametrize("order", [rows_order_numpy, "numba"])
def test_rows_order_sorts_flies_by_image_row_stably(order):
    rng = np.random.default_rng(2)
    n = 3000
    u, v = rng.uniform(-50, 370, n), rng.uniform(-50, 290, n)  # some off the image
    xyz = SMALL.backproject(u, v, rng.uniform(0.5, 20.0, n))
    xyz[::97, 0] = SMALL.mount_x - 0.5  # behind the cameras
    xyz[::89, 0] = SMALL.mount_x  # in the cameras' plane: a division by zero
    xyz[1::7] = xyz[::7][: len(xyz[1::7])]  # equal flies: their order must be kept
    index = np.sort(rng.choice(n, 2000, replace=False)).astype(np.int64)
    if order == "numba":
        scratch = np.empty((3, max(n, SMALL.height + 2)), dtype=np.int64)
        got = rows_order_into(xyz, index, rig_constants(SMALL), SMALL.height, scratch).copy()
    else:
        got = order(xyz, index, SMALL)
    np.testing.assert_array_equal(got, rows_order_numpy(xyz, index, SMALL))
    assert sorted(got.tolist()) == index.tolist()
    _, _, v, depth = SMALL.project(xyz[got])
    on = (depth > 0) & (v >= 0) & (v < SMALL.height)
    off = np.count_nonzero(~on)
    assert 0 < off < len(got) and not on[:off].any()  # off the image first, then by row
    assert np.all(np.diff(np.floor(v[off:])) >= 0)


@pytest.fixture(scope="module")
def scene():
    post = ((0.9, -0.32, 0.0), (1.0, -0.22, 0.45))
    panel = ((2.0, -0.2, 0.0), (2.1, 0.6, 0.9))
    world = room(post, panel)
    pair, _ = render(world, SMALL)
    return pair, default_sonar_reading(world)


def _replayed(config, scene, seed=5):
    """Frames, sonar, odometry (a turn, so scouts go out) and steps, as replay calls them."""
    pair, reading = scene
    engine = FlyEngine(config, SMALL, np.random.default_rng(seed))
    stats = []
    for frame in range(3):
        engine.set_images(pair)  # every fly stale, their bonus unchanged (no motion yet)
        if frame == 0:
            engine.set_sonar(reading)
        for step in range(4):
            if step >= 2:  # turning: the next frame's immigrants scout
                engine.apply_motion(Pose2D(0.01, 0.0, -0.03))
            stats.append(engine.step())
            if frame == 1 and step == 0:
                engine.set_sonar(reading)  # a new reading: every fly's bonus recomputed
    return engine, stats


@pytest.mark.parametrize("parallel_min", [engine_module.PARALLEL_MIN_EVALUATIONS, 300])
def test_one_call_per_generation_equals_the_numpy_steps(scene, parallel_min, monkeypatch):
    # 300: the parallel fitness kernel scores the stale flies before the one call
    monkeypatch.setattr(engine_module, "PARALLEL_MIN_EVALUATIONS", parallel_min)
    cfg = EngineConfig(flies=600)
    a, stats_a = _replayed(cfg, scene)
    b, stats_b = _replayed(dataclasses.replace(cfg, backend=Backend.NUMPY), scene)
    assert stats_a == stats_b
    assert any(s.evaluations > cfg.flies for s in stats_a)  # new images re-scored every fly
    assert any(s.sonar_immigrants > 0 for s in stats_a)
    newcomers = cfg.flies - cfg.survivors
    assert any(s.evaluations - newcomers not in (0, cfg.flies) for s in stats_a)  # scouts
    pa, pb = a.population, b.population
    for field in ("xyz", "fitness", "vision", "stale", "stamp_ns", "age"):
        np.testing.assert_array_equal(getattr(pa, field), getattr(pb, field), err_msg=field)


def _replayed_in_batches(config, scene, seed=5):
    """:func:`_replayed` with each run of generations that nothing comes between made by
    one :meth:`FlyEngine.steps` call (replay's rhythm between two ticks)."""
    pair, reading = scene
    engine = FlyEngine(config, SMALL, np.random.default_rng(seed))
    stats = []
    for frame in range(3):
        engine.set_images(pair)
        if frame == 0:
            engine.set_sonar(reading)
        if frame == 1:
            stats += engine.steps(1)
            engine.set_sonar(reading)
            stats += engine.steps(1)
        else:
            stats += engine.steps(2)
        for _ in range(2):
            engine.apply_motion(Pose2D(0.01, 0.0, -0.03))
            stats += engine.steps(1)
    return engine, stats


@pytest.mark.parametrize("parallel_min", [engine_module.PARALLEL_MIN_EVALUATIONS, 300])
@pytest.mark.parametrize("backend", [Backend.NUMBA, Backend.NUMPY])
def test_generations_in_one_call_equal_the_numpy_steps(scene, parallel_min, backend, monkeypatch):
    monkeypatch.setattr(engine_module, "PARALLEL_MIN_EVALUATIONS", parallel_min)
    cfg = EngineConfig(flies=600)
    a, stats_a = _replayed_in_batches(dataclasses.replace(cfg, backend=backend), scene)
    b, stats_b = _replayed(dataclasses.replace(cfg, backend=Backend.NUMPY), scene)
    assert stats_a == stats_b
    pa, pb = a.population, b.population
    for field in ("xyz", "fitness", "vision", "stale", "stamp_ns", "age"):
        np.testing.assert_array_equal(getattr(pa, field), getattr(pb, field), err_msg=field)


@pytest.mark.parametrize("count", [1, 2, 3, 7])
def test_steps_equal_as_many_steps(scene, count):
    pair, reading = scene
    runs = []
    for batched in (False, True):
        engine = FlyEngine(EngineConfig(flies=600), SMALL, np.random.default_rng(9))
        engine.set_images(pair)
        engine.set_sonar(reading)
        stats = engine.steps(count) if batched else [engine.step() for _ in range(count)]
        stats += engine.steps(count) if batched else [engine.step() for _ in range(count)]
        runs.append((engine.population, stats, engine.generation))
    (pa, sa, ga), (pb, sb, gb) = runs
    assert sa == sb and ga == gb == 2 * count
    for field in ("xyz", "fitness", "vision", "stale", "stamp_ns", "age"):
        np.testing.assert_array_equal(getattr(pa, field), getattr(pb, field), err_msg=field)
    assert FlyEngine(EngineConfig(flies=100), SMALL, np.random.default_rng(0)).steps(0) == []
