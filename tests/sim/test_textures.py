import numpy as np

from flylog.sim.textures import hash01_numpy, texture_column, texture_value_numpy


def _points(n=400, seed=0):
    rng = np.random.default_rng(seed)
    s = rng.uniform(-50.0, 50.0, n)
    t = rng.uniform(-5.0, 5.0, n)
    seeds = rng.integers(0, 100, n)
    footprint = 10.0 ** rng.uniform(-4.0, -0.5, n)
    return s, t, seeds, footprint


def test_hash_is_uniform_in_unit_interval():
    rng = np.random.default_rng(1)
    ix, iy = rng.integers(-(10**6), 10**6, (2, 2000))
    seed = rng.integers(0, 1000, 2000)
    ref = hash01_numpy(ix, iy, seed)
    assert ref.min() >= 0.0 and ref.max() < 1.0
    assert abs(ref.mean() - 0.5) < 0.03


def _column(s, t, seeds, feature, footprint, lo, hi):
    n = len(s)
    out = np.full(n, np.nan)
    texture_column(s, t, seeds, np.full(n, feature), footprint, lo, hi, out, np.empty((3, n)))
    return out


# The compiled column kernel may contract multiply-adds (FMA) where numpy rounds twice: the
# two agree to float rounding, not bit for bit (uint8 colours absorb it; the fixture logs
# reproduce byte for byte). 1e-12 is a million times tighter than one grey level.
RTOL = 1e-12


def test_texture_column_matches_numpy_reference():
    # Random points and footprints from 0.1 mm to 30 cm: every octave fully visible, fading
    # or faded out, in no order (the column kernel finds the rows where each is visible).
    s, t, seeds, footprint = _points()
    s = s - 1e4  # negative lattice coordinates too
    ref = texture_value_numpy(s, t, seeds, 0.04, footprint)
    got = _column(s, t, seeds, 0.04, footprint, 0, len(s))
    np.testing.assert_allclose(got, ref, rtol=RTOL, atol=RTOL)
    # The same for a run of rows that each octave covers only in part.
    ramp = np.geomspace(1e-4, 0.3, len(s))
    ref = texture_value_numpy(s, t, seeds, 0.04, ramp)
    np.testing.assert_allclose(
        _column(s, t, seeds, 0.04, ramp, 0, len(s)), ref, rtol=RTOL, atol=RTOL
    )


def test_texture_column_writes_only_rows_lo_to_hi():
    s, t, seeds, footprint = _points(50)
    got = _column(s, t, seeds, 0.04, footprint, 10, 30)
    assert np.all(np.isnan(got[:10])) and np.all(np.isnan(got[30:]))
    ref = texture_value_numpy(s, t, seeds, 0.04, footprint)[10:30]
    np.testing.assert_allclose(got[10:30], ref, rtol=RTOL, atol=RTOL)


def test_texture_fades_to_mean_far_away_and_has_contrast_near():
    s, t, seeds, _ = _points()
    far = texture_value_numpy(s, t, seeds, 0.04, 1.0)  # a pixel covers 1 m: no detail left
    assert np.all(far == 0.5)
    near = texture_value_numpy(s, t, seeds, 0.04, 0.002)
    assert near.std() > 0.05
    # Same point, same texture (what makes both cameras agree); another seed differs.
    assert np.array_equal(near, texture_value_numpy(s, t, seeds, 0.04, 0.002))
    assert not np.array_equal(near, texture_value_numpy(s, t, seeds + 1, 0.04, 0.002))
