"""engine.similarity = zncc and engine.subpixel: the compiled kernels against the numpy
references, and ZNCC's invariance to a gain and an offset between the cameras."""

import numba
import numpy as np
import pytest

from flylog.fly import fitness_vector
from flylog.fly.config import Gradient, Similarity
from flylog.fly.fitness import INVALID_FITNESS, fitness_numba, fitness_numpy
from flylog.fly.fitness_terms import FRACTION, sobel_norm2, windows_into
from flylog.fly.measures import CORRELATION, DIFFERENCE, NCC_SCALE, measure_of
from tests.fly.plain_patches import SMALL, plain_fitness, random_case

ZNCC = Similarity.ZNCC


def _zncc_unlike(dl, dr):
    """The module docstring's formula, independent of the integer sums."""
    norm = np.sqrt((dl * dl).sum() * (dr * dr).sum())
    zncc = (dl * dr).sum() / norm if norm > 0 else 0.0
    return dl.size * NCC_SCALE * (1.0 - zncc)


def _plain_zncc_fitness(left, right, xyz, window, guard):
    return plain_fitness(left, right, xyz, window, guard, _zncc_unlike)


@pytest.mark.parametrize("similarity", [ZNCC, Similarity.GAIN_ZSSD, Similarity.CONTRAST_ZNCC])
@pytest.mark.parametrize("gradient", list(Gradient))
@pytest.mark.parametrize("channels", [1, 3, 5])
@pytest.mark.parametrize("window", [3, 7, 11])
def test_normalised_kernels_equal_numpy_reference(similarity, gradient, channels, window):
    """The measures on ZNCC's sums (zncc, gain_zssd, contrast_zncc), compiled against numpy."""
    left, right, xyz = random_case(window * 10 + channels, channels)
    want = fitness_numpy(
        left, right, xyz, SMALL, window, 1.0, gradient=gradient, similarity=similarity
    )
    assert (want > 0).sum() > 20
    for parallel_min in (0, 10**9):
        got = fitness_numba(
            left,
            right,
            xyz,
            SMALL,
            window,
            1.0,
            gradient=gradient,
            similarity=similarity,
            parallel_min=parallel_min,
        )
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("channels", [1, 3])
def test_zncc_reference_equals_plain_formula(channels):
    left, right, xyz = random_case(7, channels)
    want = _plain_zncc_fitness(left, right, xyz, 7, 1.0)
    got = fitness_numpy(left, right, xyz, SMALL, 7, 1.0, similarity=ZNCC)
    np.testing.assert_array_equal(got == INVALID_FITNESS, want == INVALID_FITNESS)
    np.testing.assert_allclose(got, want, rtol=1e-9)


@pytest.mark.parametrize("channels", [1, 3])
def test_zncc_fitness_ignores_gain_and_offset_of_the_right_image(channels):
    # Pixels below 128: 2·R + 1 stays in uint8 with no clipping, and the ZNCC is the same
    # float to the last bit (a power-of-two gain scales the sums exactly).
    left, right, xyz = random_case(3, channels)
    brighter = (2 * right.astype(np.int64) + 1).astype(np.uint8)
    base = fitness_numba(left, right, xyz, SMALL, 7, 1.0, similarity=ZNCC)
    lit = fitness_numba(left, brighter, xyz, SMALL, 7, 1.0, similarity=ZNCC)
    np.testing.assert_array_equal(lit, base)
    zssd = fitness_numba(left, brighter, xyz, SMALL, 7, 1.0)
    assert not np.array_equal(zssd, fitness_numba(left, right, xyz, SMALL, 7, 1.0))


def test_zncc_perfect_match_is_the_guard_and_flat_patch_scores_zero():
    rng = np.random.default_rng(5)
    left = rng.integers(0, 256, (SMALL.height, SMALL.width), dtype=np.uint8)
    far = SMALL.backproject(np.array([30.0]), np.array([20.0]), np.array([1e9]))  # same column
    same = fitness_numba(left, left, far, SMALL, 7, 1.0, similarity=ZNCC)
    c = left[19:22, 29:32].astype(np.int64)
    gx = (c[:, 2] - c[:, 0]) @ np.array([1, 2, 1])
    gy = (c[2] - c[0]) @ np.array([1, 2, 1])
    assert same[0] == pytest.approx(np.sqrt(np.hypot(gx, gy)) / 49.0, rel=1e-12)
    flat = np.full_like(left, 90)
    assert fitness_numba(flat, flat, far, SMALL, 7, 1.0, similarity=ZNCC)[0] == 0.0


@pytest.mark.parametrize("similarity", list(Similarity))
@pytest.mark.parametrize("channels", [1, 3, 5])
@pytest.mark.parametrize("window", [3, 7, 11])
def test_subpixel_kernel_equals_numpy_reference(similarity, channels, window):
    left, right, xyz = random_case(window + channels, channels)
    want = fitness_numpy(left, right, xyz, SMALL, window, 1.0, similarity=similarity, subpixel=True)
    assert (want > 0).sum() > 20
    for parallel_min in (0, 10**9):
        got = fitness_numba(
            left,
            right,
            xyz,
            SMALL,
            window,
            1.0,
            similarity=similarity,
            subpixel=True,
            parallel_min=parallel_min,
        )
        np.testing.assert_array_equal(got, want)


def test_subpixel_finds_a_half_pixel_shift_that_whole_pixels_miss():
    # A smooth texture, the right image the left one moved by 4.5 px: the fly at the true
    # disparity matches almost exactly when sampled between pixels, not when rounded.
    x = np.arange(SMALL.width, dtype=np.float64)
    y = np.arange(SMALL.height, dtype=np.float64)[:, None]

    def texture(u):
        return 128 + 60 * np.sin(0.35 * u + 0.2 * y) + 40 * np.cos(0.23 * u - 0.31 * y)

    left = np.rint(texture(x)).astype(np.uint8)
    right = np.rint(texture(x + 4.5)).astype(np.uint8)
    depth = SMALL.fb / (4.5 + SMALL.doffs)
    u, v = np.meshgrid(np.arange(12, 52, 3.0), np.arange(8, 40, 3.0))
    xyz = SMALL.backproject(u.ravel(), v.ravel(), np.full(u.size, depth))
    exact = fitness_numba(left, right, xyz, SMALL, 7, 1.0, subpixel=True)
    rounded = fitness_numba(left, right, xyz, SMALL, 7, 1.0)
    assert np.median(exact / rounded) > 2.0


def _border_case(seed, channels, window, n=400):
    # Flies whose windows touch the images' edges: the left projection within two pixels of
    # the first or last valid column and row, 0-4 px of disparity (the right window too).
    rng = np.random.default_rng(seed)
    shape = (SMALL.height, SMALL.width) + ((channels,) if channels > 1 else ())
    left = rng.integers(0, 256, shape, dtype=np.uint8)
    right = rng.integers(0, 256, shape, dtype=np.uint8)
    h = window // 2

    def near_edges(size):
        low = rng.uniform(h - 2, h + 6, n)
        high = rng.uniform(size - 1 - h - 2, size - 1 - h + 2, n)
        return np.where(rng.random(n) < 0.5, low, high)

    u, v = near_edges(SMALL.width), near_edges(SMALL.height)
    disparity = rng.uniform(0.0, 4.0, n)
    return left, right, SMALL.backproject(u, v, SMALL.fb / (disparity + SMALL.doffs))


# Every window the vector kernels take: window·channels ≤ 32 bytes a row, 16 or 32 lanes.
VECTOR_WINDOWS = [(c, w) for c in (1, 3, 4) for w in range(3, 33, 2) if w * c <= 32]


@pytest.mark.parametrize("similarity", list(Similarity))
@pytest.mark.parametrize(("channels", "window"), VECTOR_WINDOWS)
def test_subpixel_kernel_equals_numpy_reference_at_the_borders(similarity, channels, window):
    left, right, xyz = _border_case(channels * 100 + window, channels, window)
    want = fitness_numpy(left, right, xyz, SMALL, window, 1.0, similarity=similarity, subpixel=True)
    assert (want > 0).sum() > 40
    assert (want == INVALID_FITNESS).sum() > 40
    got = fitness_numba(left, right, xyz, SMALL, window, 1.0, similarity=similarity, subpixel=True)
    np.testing.assert_array_equal(got, want)


PAIR_SUMS = [fitness_vector.pair_sums_generic] + (
    [fitness_vector.pair_sums_x86] if fitness_vector.target_has_avx2() else []
)


# The vector intrinsics' factory of each kind of window sums that has vector forms.
FACTORIES = {
    DIFFERENCE: fitness_vector.window_terms_intrinsic,
    CORRELATION: fitness_vector.ncc_terms_intrinsic,
}
VECTOR_MEASURES = [s for s in Similarity if measure_of(s).sums.vector is not None]


def test_every_measure_with_vector_sums_is_checked_below():
    assert {measure_of(s).sums for s in VECTOR_MEASURES} <= set(FACTORIES)


@pytest.mark.parametrize("pair_sums", PAIR_SUMS, ids=lambda f: f.__name__)
@pytest.mark.parametrize("similarity", VECTOR_MEASURES)
@pytest.mark.parametrize(("halves", "window", "channels"), [(1, 5, 3), (2, 7, 3), (2, 31, 1)])
def test_subpixel_vector_terms_equal_the_copied_windows_for_every_weight(
    pair_sums, similarity, halves, window, channels
):
    # The interpolating intrinsics against the lane loop on windows copied by windows_into,
    # for every weight q, on random bytes and on right rows of 0 and 255 (the largest |b − a|).
    sums = measure_of(similarity).sums
    terms = FACTORIES[sums](pair_sums, halves, subpixel=True)
    lanes = sums.lanes

    @numba.njit
    def vector(left, right, bl, br, stride, window, channels, q):
        masks = fitness_vector.lane_masks(window, channels, 1)
        return terms(left, right, bl, br, stride, window, masks, q, channels)

    rng = np.random.default_rng(halves * 100 + window)
    stride, bs = 120, 40
    lbuf = np.zeros(window * bs, dtype=np.uint8)
    rbuf = np.zeros(window * bs, dtype=np.uint8)
    scratch = np.empty((5, window * channels), dtype=np.int32)
    for case in ("random", "salt"):
        left = rng.integers(0, 256, 40 * stride, dtype=np.uint8)
        right = rng.integers(0, 256, 40 * stride, dtype=np.uint8)
        if case == "salt":
            right = (255 * (rng.random(right.size) < 0.5)).astype(np.uint8)
        bl, br = int(rng.integers(stride, 2 * stride)), int(rng.integers(stride, 2 * stride))
        for q in range(FRACTION):
            windows_into(left, right, bl, br, stride, window, channels, q, lbuf, rbuf, bs)
            centre = (window // 2) * (bs + channels)
            grad2 = sobel_norm2(lbuf, centre, bs, channels, 1)
            got = vector(left, right, bl, br, stride, window, channels, q)
            want = (*lanes(lbuf, rbuf, 0, 0, bs, window, channels, scratch), grad2)
            assert got == want, (case, q)
