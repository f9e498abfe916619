"""engine.similarity = sad: the compiled kernel (lane loop only) against the numpy
reference, the reference against a plain float formula, and what an offset does to it."""

import numpy as np
import pytest

from flylog.fly.config import Gradient, Similarity
from flylog.fly.fitness import INVALID_FITNESS, fitness_numba, fitness_numpy
from tests.fly.plain_patches import SMALL, random_case

SAD = Similarity.SAD


def _plain_sad_fitness(left, right, xyz, window, guard):
    """G / (guard·n·C + (Σ|L − R|)²/(n·C)) fly by fly in floats, G the paper's Sobel norm."""
    left = left.reshape(left.shape[0], left.shape[1], -1).astype(np.float64)
    right = right.reshape(left.shape).astype(np.float64)
    h = window // 2
    ul, ur, v, depth = SMALL.project(xyz)
    out = np.full(len(xyz), INVALID_FITNESS)
    for i in range(len(xyz)):
        a, b, r = (int(np.floor(x + 0.5)) for x in (ul[i], ur[i], v[i]))
        inside = h <= r < SMALL.height - h and all(h <= c < SMALL.width - h for c in (a, b))
        if depth[i] <= 0 or not inside:
            continue
        pl = left[r - h : r + h + 1, a - h : a + h + 1]
        pr = right[r - h : r + h + 1, b - h : b + h + 1]
        c = pl[h - 1 : h + 2, h - 1 : h + 2]
        gx = (c[:, 2] - c[:, 0]) * np.array([1, 2, 1])[:, None]
        gy = (c[2] - c[0]) * np.array([1, 2, 1])[:, None]
        g = np.sqrt(np.sqrt((gx.sum(axis=0) ** 2 + gy.sum(axis=0) ** 2).sum()))
        sad = np.abs(pl - pr).sum()
        out[i] = g / (guard * pl.size + sad * sad / pl.size)
    return out


@pytest.mark.parametrize("gradient", list(Gradient))
@pytest.mark.parametrize("channels", [1, 3])
@pytest.mark.parametrize("window", [3, 7, 13])
@pytest.mark.parametrize("subpixel", [False, True])
def test_sad_kernel_equals_numpy_reference(gradient, channels, window, subpixel):
    left, right, xyz = random_case(window * 10 + channels, channels)
    kwargs = {"gradient": gradient, "similarity": SAD, "subpixel": subpixel}
    want = fitness_numpy(left, right, xyz, SMALL, window, 1.0, **kwargs)
    assert (want > 0).sum() > 20
    for parallel_min in (0, 10**9):
        got = fitness_numba(
            left, right, xyz, SMALL, window, 1.0, parallel_min=parallel_min, **kwargs
        )
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("channels", [1, 3])
def test_sad_reference_equals_plain_formula(channels):
    left, right, xyz = random_case(11, channels)
    want = _plain_sad_fitness(left, right, xyz, 7, 1.0)
    got = fitness_numpy(left, right, xyz, SMALL, 7, 1.0, similarity=SAD)
    np.testing.assert_array_equal(got == INVALID_FITNESS, want == INVALID_FITNESS)
    np.testing.assert_allclose(got, want, rtol=1e-12)


def test_sad_counts_an_offset_that_zssd_removes():
    left = random_case(5, 3)[0]
    far = SMALL.backproject(np.full(50, 30.0), np.full(50, 20.0), np.full(50, 1e6))
    brighter = left + np.uint8(20)  # pixels below 128: no wrap
    same = {
        s: fitness_numba(left, left, far, SMALL, 7, 1.0, similarity=s)
        for s in (SAD, Similarity.ZSSD)
    }
    lit = {
        s: fitness_numba(left, brighter, far, SMALL, 7, 1.0, similarity=s)
        for s in (SAD, Similarity.ZSSD)
    }
    np.testing.assert_array_equal(lit[Similarity.ZSSD], same[Similarity.ZSSD])
    assert (same[SAD] > 0).all() and (lit[SAD] < same[SAD] / 10).all()
