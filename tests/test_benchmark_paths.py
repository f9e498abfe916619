"""The benchmarks are not run by the test suite (timings belong to `make bench`), but the
files they read must exist: a moved fixture would otherwise only show in `make bench`."""

from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path

import numpy as np
import pytest

from tests import benchmarks

MODULES = sorted(
    m.name for m in pkgutil.iter_modules(benchmarks.__path__) if m.name.startswith("bench_")
)


@pytest.mark.parametrize("name", MODULES)
def test_every_path_a_benchmark_names_exists(name):
    module = importlib.import_module(f"tests.benchmarks.{name}")
    assert callable(module.run)
    for attr, value in vars(module).items():
        if isinstance(value, Path):
            assert value.exists(), f"{name}.{attr} = {value} does not exist"


@pytest.mark.parametrize("parallel", [False, True])
def test_the_level_only_reference_kernel_agrees_with_the_rig_kernel(parallel):
    """bench_fly times the rig's kernel against the level-only kernel: both must compile
    against today's helpers and give the same fitness on a level rig."""
    from flylog.fly.config import Gradient
    from flylog.fly.fitness import fitness_into, images_of
    from flylog.fly.measures import ZSSD
    from flylog.geometry import StereoRig
    from tests.benchmarks.level_fitness import level_constants, level_fitness

    rig = StereoRig(width=64, height=48)
    rng = np.random.default_rng(3)
    left = rng.integers(0, 256, (48, 64, 3), dtype=np.uint8)
    right = np.roll(left, -4, axis=1)
    n = 400
    u, v = rng.uniform(3, 60, n), rng.uniform(3, 44, n)
    xyz = np.ascontiguousarray(rig.backproject(u, v, 1.0 / rng.uniform(0.05, 2.0, n)))
    index = np.arange(n, dtype=np.int64)
    rows = (left.reshape(48, 64 * 3), right.reshape(48, 64 * 3), 3)
    level, general = np.empty(n), np.empty(n)
    level_fitness(*rows, xyz, index, level_constants(rig), level, parallel=parallel)
    im = images_of(left, right, rig, 7, 1.0, gradient=Gradient.NORM)
    fitness_into(im, ZSSD, xyz, index, general, parallel_min=0 if parallel else n + 1)
    np.testing.assert_array_equal(level, general)
    assert np.isfinite(level).sum() > n // 2
