import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flylog.fly import fitness_vector
from flylog.fly.config import Gradient
from flylog.fly.fitness import (
    INVALID_FITNESS,
    fitness_numba,
    fitness_numpy,
    left_projections_numba,
    rig_constants,
)
from flylog.fly.fitness_terms import sobel_norm2
from flylog.fly.measures import zssd_lanes
from flylog.geometry import StereoRig
from tests.fly.analytic import render, room

SMALL = StereoRig(width=64, height=48, focal_px=50.0, baseline=0.12)


def _numba_serial(*args, **kwargs):
    return fitness_numba(*args, parallel_min=10**9, **kwargs)


def _numba_parallel(*args, **kwargs):
    return fitness_numba(*args, parallel_min=0, **kwargs)


IMPLEMENTATIONS = [fitness_numpy, _numba_serial, _numba_parallel]


@st.composite
def cases(draw):
    seed = draw(st.integers(0, 2**32 - 1))
    # Rows of up to 32 bytes and 4 channels take the vector path (16 or 32 lanes); wider rows
    # (11 × 3, 9 × 4, 15, 23) and 5 channels the lane-loop one.
    channels = draw(st.sampled_from([1, 2, 3, 4, 5]))
    window = draw(st.sampled_from([3, 5, 7, 9, 11, 15, 23]))
    rng = np.random.default_rng(seed)
    shape = (SMALL.height, SMALL.width) + ((3,) if channels == 3 else ())
    left = rng.integers(0, 256, shape, dtype=np.uint8)
    right = rng.integers(0, 256, shape, dtype=np.uint8)
    n = draw(st.integers(1, 60))
    # Projections from well outside to well inside, depths from behind to far.
    u = rng.uniform(-20, SMALL.width + 20, n)
    v = rng.uniform(-20, SMALL.height + 20, n)
    depth = rng.choice([-1.0, 0.0, 1.0], n) * rng.uniform(0.05, 10.0, n)
    xyz = SMALL.backproject(u, v, np.where(depth == 0, 1.0, depth))
    xyz[depth == 0, 0] = SMALL.mount_x  # exactly in the camera plane
    return left, right, xyz, window


@pytest.mark.parametrize("gradient", list(Gradient))
@settings(max_examples=60, deadline=None)
@given(case=cases())
def test_numba_kernel_equals_numpy_reference(gradient, case):
    left, right, xyz, window = case
    expected = fitness_numpy(left, right, xyz, SMALL, window, 1.0, gradient=gradient)
    for impl in (_numba_serial, _numba_parallel):
        got = impl(left, right, xyz, SMALL, window, 1.0, gradient=gradient)
        np.testing.assert_array_equal(got, expected)


@pytest.mark.parametrize("gradient", list(Gradient))
@pytest.mark.parametrize("channels", [1, 3])
@pytest.mark.parametrize("window", [5, 7, 15])
def test_windows_at_the_image_end_equal_numpy_reference(channels, window, gradient):
    # The last rows' vector reads would pass the end of the image: the scalar path takes them.
    rng = np.random.default_rng(window * channels)
    shape = (SMALL.height, SMALL.width) + ((channels,) if channels > 1 else ())
    left = rng.integers(0, 256, shape, dtype=np.uint8)
    right = rng.integers(0, 256, shape, dtype=np.uint8)
    h = window // 2
    u, v = np.meshgrid(np.arange(h, SMALL.width - h), np.arange(SMALL.height - h - 3, SMALL.height))
    xyz = SMALL.backproject(u.ravel(), v.ravel(), np.full(u.size, 1e4))  # right ≈ left column
    expected = fitness_numpy(left, right, xyz, SMALL, window, 1.0, gradient=gradient)
    assert (expected > 0).sum() > 100
    got = _numba_serial(left, right, xyz, SMALL, window, 1.0, gradient=gradient)
    np.testing.assert_array_equal(got, expected)


@numba.njit
def _scalar_terms(left, right, bl, br, stride, window, channels, gy_weight):
    h = window // 2
    centre = bl + h * stride + h * channels
    scratch = np.empty((2, window * channels), dtype=np.int32)
    return (
        *zssd_lanes(left, right, bl, br, stride, window, channels, scratch),
        sobel_norm2(left, centre, stride, channels, gy_weight),
    )


PAIR_SUMS = [fitness_vector.pair_sums_generic] + (
    [fitness_vector.pair_sums_x86] if fitness_vector.target_has_avx2() else []
)


# (window, channels) pairs whose rows take 1 and 2 vectors of 16 lanes.
WINDOWS_BY_VECTORS = {
    1: [(3, 1), (3, 4), (5, 3), (15, 1)],
    2: [(7, 3), (9, 3), (7, 4), (16, 2), (31, 1)],
}


@pytest.mark.parametrize("vectors", sorted(WINDOWS_BY_VECTORS))
@pytest.mark.parametrize("pair_sums", PAIR_SUMS, ids=lambda f: f.__name__)
def test_vector_window_terms_equal_scalar_ones(pair_sums, vectors):
    terms = fitness_vector.window_terms_intrinsic(pair_sums, vectors)

    @numba.njit
    def vector_terms(left, right, bl, br, stride, window, channels, gy_weight):
        masks = fitness_vector.lane_masks(window, channels, gy_weight)
        return terms(left, right, bl, br, stride, window, masks)

    rng = np.random.default_rng(vectors)
    stride = 200
    for window, channels in WINDOWS_BY_VECTORS[vectors]:
        assert -(-window * channels // 16) == vectors
        # Random bytes; all 255 against all 0 (the largest sums the lanes hold); random 0 or 255
        # against 0 (the steepest gradients).
        for case in ("random", "saturated", "salt"):
            left = rng.integers(0, 256, 64 * stride, dtype=np.uint8)
            right = rng.integers(0, 256, 64 * stride, dtype=np.uint8)
            if case != "random":
                right[:] = 0
                left[:] = 255 if case == "saturated" else 255 * (rng.random(left.size) < 0.5)
            bl, br = int(rng.integers(0, 100)), int(rng.integers(0, 100))
            want = {}
            for gy_weight in (1, 0):  # the Sobel norm², then gx² alone
                want[gy_weight] = _scalar_terms(
                    left, right, bl, br, stride, window, channels, gy_weight
                )
                got = vector_terms(left, right, bl, br, stride, window, channels, gy_weight)
                assert got == want[gy_weight], (window, channels, case, gy_weight)
            assert want[0][:2] == want[1][:2] and want[0][2] <= want[1][2]
            n = window * window
            if case != "saturated":
                assert n * want[1][0] - want[1][1] > 0 and want[1][2] > 0
            if case == "random":  # both derivatives non-zero: dropping gy changes the norm
                assert want[1][2] > want[0][2] > 0


@pytest.fixture(scope="module")
def frame():
    rig = StereoRig(width=160, height=120, focal_px=125.0)
    pair, depth = render(room(((2.0, -0.3, 0.0), (2.1, 0.5, 0.9))), rig)
    return rig, pair, depth


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
def test_fly_on_surface_beats_same_fly_off_it(impl, frame):
    rig, pair, depth = frame
    rng = np.random.default_rng(3)
    u = rng.uniform(10, rig.width - 11, 400)
    v = rng.uniform(10, rig.height - 11, 400)
    # Pixel centres, so the fly's rounded projections are exactly the rendered pixels.
    u, v = np.round(u), np.round(v)
    z = depth[v.astype(int), u.astype(int)]
    on = impl(pair.left, pair.right, rig.backproject(u, v, z), rig, 7, 1.0)
    for factor in (0.8, 1.25):
        off = impl(pair.left, pair.right, rig.backproject(u, v, z * factor), rig, 7, 1.0)
        both = (on > 0) & (off > 0)
        assert both.sum() > 300
        assert np.mean(on[both] > off[both]) > 0.95


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
def test_grey_and_colour_agree_on_flat_grey_texture(impl):
    rng = np.random.default_rng(0)
    grey = rng.integers(0, 256, (SMALL.height, SMALL.width), dtype=np.uint8)
    colour = np.repeat(grey[:, :, None], 3, axis=2)
    xyz = SMALL.backproject(np.array([30.0]), np.array([20.0]), np.array([2.0]))
    g = impl(grey, np.roll(grey, -3, axis=1), xyz, SMALL, 5, 1.0)
    c = impl(colour, np.roll(colour, -3, axis=1), xyz, SMALL, 5, 1.0)
    # Three identical channels: gradient norm × √3 (G × 3^¼), denominator × 3.
    assert c[0] == pytest.approx(g[0] * 3**0.25 / 3)


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
def test_known_patch_value(impl):
    # A horizontal ramp L(u) = 10u, shifted by the fly's disparity in R plus a constant:
    # the zero-mean SSD is exactly 0 and Sobel gx = 4·10·... per channel.
    rig = StereoRig(width=32, height=24, focal_px=30.0, baseline=0.1)
    u = np.arange(rig.width)
    left = np.tile((5 * u).astype(np.uint8), (rig.height, 1))
    disparity = 3
    right = np.tile((5 * (u + disparity) + 7).astype(np.uint8), (rig.height, 1))
    depth = rig.focal_px * rig.baseline / disparity
    xyz = rig.backproject(np.array([12.0]), np.array([10.0]), np.array([depth]))
    got = impl(left, right, xyz, rig, 5, 0.5)
    gx = 2 * 5 * (1 + 2 + 1)  # Sobel on a ramp of slope 5
    assert got[0] == pytest.approx(np.sqrt(gx) / (0.5 * 25))


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
def test_invalid_flies_get_lowest_fitness(impl, frame):
    rig, pair, _ = frame
    h = 3
    xyz = rig.backproject(
        np.array([h, h - 1, rig.width - 1 - h, rig.width - h, 80.0, 80.0]),
        np.array([60.0, 60.0, 60.0, 60.0, h - 1, 60.0]),
        np.array([50.0, 50.0, 50.0, 50.0, 2.0, 2.0]),
    )
    behind = xyz[5].copy()
    behind[0] = rig.mount_x - 1.0
    xyz[5] = behind
    got = impl(pair.left, pair.right, xyz, rig, 7, 1.0)
    # Far flies: right projection ≈ left one; u = h is the first column whose window fits.
    assert got[0] >= 0 and got[2] >= 0
    assert list(got[[1, 3, 4, 5]]) == [INVALID_FITNESS] * 4


STEP = StereoRig(width=48, height=32, focal_px=40.0, baseline=0.1)


def _step_edge_flies(vertical: bool, disparities: np.ndarray):
    """A 50 → 200 step edge in both images (vertical: between columns 23 and 24, the right
    image shifted by 6 px; horizontal: between rows 15 and 16, the same in both images), and
    flies at ``disparities`` on the edge (left projection at column 24 or row 16)."""
    u = np.arange(STEP.width)
    v = np.arange(STEP.height)
    if vertical:
        left = np.where(u[None, :] >= 24, 200, 50) + 0 * v[:, None]
        right = np.where(u[None, :] + 6 >= 24, 200, 50) + 0 * v[:, None]
        u_fly, v_fly = np.full(len(disparities), 24.0), np.full(len(disparities), 16.0)
    else:
        left = right = np.where(v[:, None] >= 16, 200, 50) + 0 * u[None, :]
        u_fly, v_fly = np.full(len(disparities), 30.0), np.full(len(disparities), 16.0)
    depth = STEP.focal_px * STEP.baseline / disparities
    xyz = STEP.backproject(u_fly, v_fly, depth)
    return left.astype(np.uint8), right.astype(np.uint8), xyz


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
def test_horizontal_gradient_gives_horizontal_edges_no_fitness(impl):
    # Aperture problem: a horizontal edge matches perfectly (ZSSD 0) at every disparity. The
    # paper's G rewards it (Sobel gy = 4 · 150); the horizontal one does not (gx = 0).
    disparities = np.array([2.0, 5.0, 9.0, 14.0])
    left, right, xyz = _step_edge_flies(False, disparities)
    norm = impl(left, right, xyz, STEP, 5, 1.0)
    horizontal = impl(left, right, xyz, STEP, 5, 1.0, gradient=Gradient.HORIZONTAL)
    np.testing.assert_allclose(norm, np.sqrt(4 * 150) / 25)
    np.testing.assert_array_equal(horizontal, 0.0)


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
def test_both_gradients_agree_on_vertical_edges(impl):
    # gy = 0 on a vertical edge: the same fitness bit for bit, highest at the true disparity.
    disparities = np.array([4.0, 5.0, 6.0, 7.0, 8.0])
    left, right, xyz = _step_edge_flies(True, disparities)
    norm = impl(left, right, xyz, STEP, 5, 1.0)
    horizontal = impl(left, right, xyz, STEP, 5, 1.0, gradient=Gradient.HORIZONTAL)
    np.testing.assert_array_equal(horizontal, norm)
    assert norm[2] == pytest.approx(np.sqrt(4 * 150) / 25)
    assert norm.argmax() == 2 and np.all(np.delete(norm, 2) < norm[2] / 100)


def test_left_projections_kernel_equals_rig_project():
    rng = np.random.default_rng(4)
    xyz = np.column_stack([rng.uniform(-1, 6, 500), rng.uniform(-3, 3, 500), rng.random(500)])
    xyz[0, 0] = SMALL.mount_x  # in the camera plane: the projection's guard
    u, _, v, _ = SMALL.project(xyz)
    got_u, got_v = left_projections_numba(xyz, rig_constants(SMALL))
    np.testing.assert_array_equal(got_u, u)
    np.testing.assert_array_equal(got_v, v)
