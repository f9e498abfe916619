"""Photometric matching of a stereo pair (flylog.fly.photometric) and the engine's use of it."""

import numpy as np
import pytest

from flylog.fly import EngineConfig, FlyEngine
from flylog.fly.config import Photometric
from flylog.fly.photometric import (
    BLUR_MAX_PX,
    BLUR_PER_NOISE,
    NOISE_FLOOR,
    blur_px,
    gain_table,
    matched,
    noise_sd,
)
from flylog.geometry import StereoRig
from flylog.sensors import StereoPair


def _textured(rng, shape=(240, 320, 3)):
    """A smooth texture (low frequencies only: Immerkær's mask reads it as almost no noise)."""
    h, w = shape[:2]
    y, x = np.mgrid[0:h, 0:w]
    base = 128 + 50 * np.sin(x / 9.0) * np.cos(y / 13.0)
    if len(shape) == 3:
        base = np.repeat(base[..., None], shape[2], axis=2)
    return base


@pytest.mark.parametrize("sigma", [3.0, 8.0])
def test_noise_estimate_reads_added_gaussian_noise(sigma):
    rng = np.random.default_rng(0)
    image = np.clip(np.rint(_textured(rng) + rng.normal(0, sigma, (240, 320, 3))), 0, 255)
    # the grey levels weigh the channels' independent noise by RGB2GRAY's 0.299, 0.587 and
    # 0.114: σ·0.668
    want = sigma * np.sqrt(0.299**2 + 0.587**2 + 0.114**2)
    assert noise_sd(image.astype(np.uint8)) == pytest.approx(want, rel=0.1)


def test_noise_estimate_of_a_smooth_image_is_small():
    rng = np.random.default_rng(0)
    image = np.clip(np.rint(_textured(rng, (240, 320))), 0, 255).astype(np.uint8)
    assert noise_sd(image) < 0.6  # the rounding's 0.29 and the texture's curvature


def test_blur_grows_with_the_noise_from_its_floor_to_its_cap():
    assert blur_px(0.0) == 0.0
    assert blur_px(NOISE_FLOOR) == 0.0
    assert blur_px(NOISE_FLOOR + 1.0) == pytest.approx(BLUR_PER_NOISE)
    assert blur_px(1000.0) == BLUR_MAX_PX


def test_gain_table_rounds_and_clips():
    table = gain_table(1.5, -10.0)
    assert table.dtype == np.uint8 and table.shape == (256,)
    assert table[0] == 0 and table[10] == 5 and table[255] == 255
    assert table[100] == 140


def test_a_gain_and_an_offset_of_the_right_camera_are_undone():
    rng = np.random.default_rng(1)
    left = np.clip(np.rint(_textured(rng)), 0, 255).astype(np.uint8)
    right = np.clip(np.rint(left * 1.25 + 6.0), 0, 255).astype(np.uint8)
    ml, mr, m = matched(left, right)
    assert m.blur_px == 0.0  # no noise: no smoothing
    assert np.array_equal(ml, left)
    assert m.gain == pytest.approx(1 / 1.25, rel=0.01)
    assert np.abs(mr.astype(int) - left.astype(int)).mean() < 0.6
    assert np.abs(right.astype(int) - left.astype(int)).mean() > 30


def test_noisy_images_are_smoothed_alike_and_shapes_kept():
    rng = np.random.default_rng(2)
    clean = _textured(rng, (120, 160))
    noisy = [
        np.clip(np.rint(clean + rng.normal(0, 8, clean.shape)), 0, 255).astype(np.uint8)
        for _ in range(2)
    ]
    ml, mr, m = matched(*noisy)
    assert m.blur_px == pytest.approx(blur_px(m.noise)) and m.blur_px > 1.0
    assert ml.shape == mr.shape == (120, 160) and ml.dtype == np.uint8
    assert np.abs(ml - clean).mean() < 0.5 * np.abs(noisy[0] - clean).mean()


def test_the_engine_scores_flies_on_the_matched_pair_and_says_which():
    rig = StereoRig(width=160, height=120)
    rng = np.random.default_rng(3)
    left = np.clip(np.rint(_textured(rng, (120, 160, 3))), 0, 255).astype(np.uint8)
    right = np.clip(np.rint(left * 1.2), 0, 255).astype(np.uint8)
    pair = StereoPair(5, left, right)
    none = FlyEngine(EngineConfig(flies=64, photometric=Photometric.NONE), rig, rng)
    assert none.set_images(pair) is pair
    engine = FlyEngine(EngineConfig(flies=64), rig, np.random.default_rng(3))
    used = engine.set_images(pair)
    assert used.stamp_ns == 5
    want_left, want_right, _ = matched(left, right)
    assert np.array_equal(used.left, want_left) and np.array_equal(used.right, want_right)
    again = FlyEngine(EngineConfig(flies=64), rig, np.random.default_rng(3)).set_images(pair)
    assert np.array_equal(again.right, used.right)
