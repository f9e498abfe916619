import numpy as np
import pytest

from flylog.sim.textures import (
    hash01,
    hash01_numpy,
    new_texture_cache,
    texture_value,
    texture_value_cached,
    texture_value_numpy,
)


def _points(n=400, seed=0):
    rng = np.random.default_rng(seed)
    s = rng.uniform(-50.0, 50.0, n)
    t = rng.uniform(-5.0, 5.0, n)
    seeds = rng.integers(0, 100, n)
    footprint = 10.0 ** rng.uniform(-4.0, -0.5, n)
    return s, t, seeds, footprint


def test_hash_numba_matches_numpy_and_is_uniform():
    rng = np.random.default_rng(1)
    ix, iy = rng.integers(-(10**6), 10**6, (2, 2000))
    seed = rng.integers(0, 1000, 2000)
    ref = hash01_numpy(ix, iy, seed)
    got = np.array([hash01(int(a), int(b), int(c)) for a, b, c in zip(ix, iy, seed, strict=True)])
    assert np.array_equal(got, ref)
    assert ref.min() >= 0.0 and ref.max() < 1.0
    assert abs(ref.mean() - 0.5) < 0.03


@pytest.mark.parametrize("impl", ["numba", "numba-cached"])
def test_texture_matches_numpy_reference(impl):
    s, t, seeds, footprint = _points()
    ref = texture_value_numpy(s, t, seeds, 0.04, footprint)
    keys, corners = new_texture_cache()
    got = []
    for a, b, c, d in zip(s, t, seeds, footprint, strict=True):
        if impl == "numba":
            got.append(texture_value(a, b, int(c), 0.04, d))
        else:
            # Repeat each point so that the second call comes from the cache.
            texture_value_cached(a, b, int(c), 0.04, d, keys, corners)
            got.append(texture_value_cached(a, b, int(c), 0.04, d, keys, corners))
    # Bit-identical but for the order of floating-point operations the compiler picks.
    np.testing.assert_allclose(np.array(got), ref, rtol=0.0, atol=1e-12)


def test_texture_fades_to_mean_far_away_and_has_contrast_near():
    s, t, seeds, _ = _points()
    far = texture_value_numpy(s, t, seeds, 0.04, 1.0)  # a pixel covers 1 m: no detail left
    assert np.all(far == 0.5)
    near = texture_value_numpy(s, t, seeds, 0.04, 0.002)
    assert near.std() > 0.05
    # Same point, same texture (what makes both cameras agree); another seed differs.
    assert np.array_equal(near, texture_value_numpy(s, t, seeds, 0.04, 0.002))
    assert not np.array_equal(near, texture_value_numpy(s, t, seeds + 1, 0.04, 0.002))
