"""The camera model: each defect measured on known inputs against the model's prediction."""

import dataclasses
import itertools
import math

import numpy as np
import pytest

from flylog.geometry import Pose2D, StereoRig
from flylog.sim.camera import (
    CameraModel,
    Drift,
    exposure_poses,
    frame_rng,
    gaussian_blur,
    gaussian_kernel,
)
from flylog.sim.camera_defects import CameraDefects, CameraPreset

RIG = StereoRig(width=320, height=240, focal_px=250.0)
# The camera model with every defect at its neutral value: a test turns on the one it measures.
PLAIN = CameraDefects(
    ideal=False,
    right_gain_ratio=1.0,
    drift_sd=0.0,
    gamma=1.0,
    shot_noise=False,
    read_noise_e=0.0,
    dsnu_e=0.0,
    prnu=0.0,
    vignetting_corner=1.0,
    psf_sigma_px=0.0,
    motion_samples=1,
)


def _model(defects: CameraDefects, seed: int = 0) -> CameraModel:
    return CameraModel(defects, RIG, seed=seed, period_s=1.0 / 15.0)


def _flat(value: float) -> np.ndarray:
    return np.full((RIG.height, RIG.width, 3), value)


def _dn_per_electron(d: CameraDefects) -> float:
    return 10.0 ** (d.gain_db / 20.0) * 255.0 / d.full_well


@pytest.mark.parametrize("electrons", [500.0, 1500.0])
def test_flat_field_noise_variance_is_the_emva_linear_models(electrons):
    """EMVA 1288: var(DN) = K²·(μe + σ_read²) + 1/12 (quantisation), mean K·μe."""
    d = dataclasses.replace(PLAIN, shot_noise=True, read_noise_e=2.5)
    value = electrons / (d.white_flux * d.exposure_ms)
    image = _model(d).expose(0, 0, _flat(value)).astype(float)
    k = _dn_per_electron(d)
    want_var = k**2 * (electrons + d.read_noise_e**2) + 1.0 / 12.0
    assert image.mean() == pytest.approx(k * electrons, rel=0.005)
    assert image.var() == pytest.approx(want_var, rel=0.03)


def test_read_noise_alone_and_shot_noise_alone_add_up():
    d = dataclasses.replace(PLAIN, read_noise_e=40.0)
    value = 1000.0 / (d.white_flux * d.exposure_ms)
    k = _dn_per_electron(d)
    read = _model(d).expose(0, 0, _flat(value)).astype(float).var()
    assert read == pytest.approx(k**2 * 40.0**2 + 1 / 12, rel=0.03)
    plain = _model(PLAIN).expose(0, 0, _flat(value))
    assert plain.var() == 0.0  # no noise: a flat field stays flat


def test_fixed_pattern_is_fixed_per_camera_and_seed_and_has_its_rms():
    d = dataclasses.replace(PLAIN, prnu=0.02)
    value = 2000.0 / (d.white_flux * d.exposure_ms)
    model = _model(d, seed=5)
    a, b = (model.expose(k, 0, _flat(value)).astype(float) for k in (0, 1))
    np.testing.assert_array_equal(a, b)  # the same pattern in every frame
    assert a.std() / a.mean() == pytest.approx(0.02, rel=0.05)
    other_camera = model.expose(0, 1, _flat(value))
    other_seed = _model(d, seed=6).expose(0, 0, _flat(value))
    assert not np.array_equal(a, other_camera) and not np.array_equal(a, other_seed)
    dark = dataclasses.replace(PLAIN, dsnu_e=30.0)
    image = _model(dark).expose(0, 0, _flat(value)).astype(float)
    assert image.std() == pytest.approx(_dn_per_electron(dark) * 30.0, rel=0.05)


def test_vignetting_at_the_corner_is_the_stated_fall_off():
    d = dataclasses.replace(PLAIN, vignetting_corner=0.7, gain_db=0.0)
    value = 0.95 * d.full_well / (d.white_flux * d.exposure_ms)  # near full scale
    image = _model(d).expose(0, 0, _flat(value)).astype(float)[..., 0]
    centre = image[119:121, 159:161].mean()  # the four pixels around (159.5, 119.5)
    for corner in (image[0, 0], image[0, -1], image[-1, 0], image[-1, -1]):
        assert corner / centre == pytest.approx(0.7, abs=1.0 / centre)
    # the cos⁴ law's profile: monotonic from the centre outwards along a row
    row = image[120, 160:]
    assert np.all(np.diff(row) <= 0)


def test_right_gain_is_the_stated_ratio_of_the_left():
    d = dataclasses.replace(PLAIN, right_gain_ratio=1.25, gain_db=0.0)
    value = 0.3 * d.full_well / (d.white_flux * d.exposure_ms)
    left, right = _model(d).pair(0, [(_flat(value * 255), _flat(value * 255))])
    assert right.mean() / left.mean() == pytest.approx(1.25, abs=1.0 / left.mean())


def test_gamma_on_a_ramp():
    d = dataclasses.replace(PLAIN, gamma=0.45, gain_db=0.0)
    scale = d.full_well / (d.white_flux * d.exposure_ms)  # rendered value whose signal is 255
    ramp = np.linspace(0.0, 1.0, RIG.width)
    radiance = np.broadcast_to(ramp[None, :, None], (RIG.height, RIG.width, 3)) * scale
    out = _model(d).expose(0, 0, np.array(radiance))[0, :, 0].astype(float)
    np.testing.assert_allclose(out, 255.0 * ramp**0.45, atol=0.5 + 1e-9)


@pytest.mark.parametrize("sigma", [0.6, 1.5])
def test_psf_sigma_is_measured_on_an_edge(sigma):
    """The derivative of the blurred step edge is the line spread: its second moment is
    sigma² (of the sampled, 3-sigma kernel)."""
    d = dataclasses.replace(PLAIN, psf_sigma_px=sigma, gain_db=0.0)
    scale = d.full_well / (d.white_flux * d.exposure_ms)
    step = np.zeros((RIG.height, RIG.width, 3))
    step[:, 160:] = 0.9 * scale
    row = _model(d).expose(0, 0, step)[100, :, 1].astype(float)
    spread = np.diff(row)
    x = np.arange(len(spread)) + 0.5
    mean = (x * spread).sum() / spread.sum()
    measured = math.sqrt(((x - mean) ** 2 * spread).sum() / spread.sum())
    kernel = gaussian_kernel(sigma)
    taps = np.arange(len(kernel)) - len(kernel) // 2
    assert measured == pytest.approx(math.sqrt((kernel * taps**2).sum()), rel=0.05)
    assert measured == pytest.approx(sigma, rel=0.1)


def test_gaussian_blur_keeps_a_flat_image_and_its_borders():
    flat = np.full((20, 30, 3), 0.4)
    np.testing.assert_allclose(gaussian_blur(flat, 2.0), flat)
    assert gaussian_blur(flat, 0.0) is flat


def test_drift_is_an_ornstein_uhlenbeck_process_of_the_stated_sd_and_time_constant():
    d = dataclasses.replace(PLAIN, drift_sd=0.1, drift_tau_s=0.2)
    period = 1.0 / 15.0
    drift = Drift(d, period, seed=2, camera=0)
    x = np.log([drift.factor(k) for k in range(20000)])
    assert x.std() == pytest.approx(0.1, rel=0.05)
    lag1 = np.corrcoef(x[:-1], x[1:])[0, 1]
    assert lag1 == pytest.approx(math.exp(-period / 0.2), abs=0.02)
    right = Drift(d, period, seed=2, camera=1)
    assert abs(np.corrcoef(x[:2000], np.log([right.factor(k) for k in range(2000)]))[0, 1]) < 0.2
    assert Drift(PLAIN, period, seed=2, camera=0).factor(50) == 1.0


def test_a_frames_noise_depends_only_on_seed_frame_and_camera():
    d = CameraDefects(ideal=False, psf_sigma_px=0.0)
    radiance = _flat(0.5)
    alone = _model(d, seed=9).expose(7, 1, radiance)
    busy = _model(d, seed=9)
    for k in range(7):
        busy.pair(k, [(radiance * 255, radiance * 255)])
    np.testing.assert_array_equal(busy.expose(7, 1, radiance), alone)
    for seed, frame, camera in ((10, 7, 1), (9, 8, 1), (9, 7, 0)):
        assert not np.array_equal(_model(d, seed=seed).expose(frame, camera, radiance), alone)
    a = frame_rng(3, 4, 1).standard_normal(5)
    np.testing.assert_array_equal(a, frame_rng(3, 4, 1).standard_normal(5))
    # disjoint from the trajectory and sonar streams (the seed's spawned children 0 and 1)
    for child in np.random.SeedSequence(3).spawn(2):
        assert not np.array_equal(a, np.random.default_rng(child).standard_normal(5))


def test_exposure_poses_spread_over_the_exposure_along_the_arc():
    pose = Pose2D(1.0, 2.0, 0.3)
    d = CameraDefects(ideal=False, motion_samples=4, exposure_ms=8.0)
    straight = exposure_poses(pose, 0.5, 0.0, d)
    assert len(straight) == 4
    steps = [math.hypot(b.x - a.x, b.y - a.y) for a, b in itertools.pairwise(straight)]
    np.testing.assert_allclose(steps, 0.5 * 0.008 / 4)
    assert np.mean([p.x for p in straight]) == pytest.approx(pose.x)
    assert np.mean([p.y for p in straight]) == pytest.approx(pose.y)
    turning = exposure_poses(pose, 0.0, 1.0, d)
    np.testing.assert_allclose(
        [p.theta - pose.theta for p in turning], [-0.003, -0.001, 0.001, 0.003], atol=1e-12
    )
    assert exposure_poses(pose, 0.5, 1.0, dataclasses.replace(d, motion_samples=1)) == [pose]


def test_motion_blur_of_a_robot_at_rest_is_its_single_render():
    d = dataclasses.replace(PLAIN, motion_samples=4)
    rng = np.random.default_rng(0)
    render = rng.integers(0, 256, (RIG.height, RIG.width, 3), dtype=np.uint8)
    poses = exposure_poses(Pose2D(0.0, 0.0, 0.0), 0.0, 0.0, d)
    assert len(set(poses)) == 1
    blurred = _model(d).pair(0, [(render, render)] * len(poses))
    single = _model(PLAIN).pair(0, [(render, render)])
    np.testing.assert_array_equal(blurred[0], single[0])


def test_presets():
    assert CameraDefects.preset(CameraPreset.IDEAL) == CameraDefects()
    assert CameraDefects().ideal
    realistic = CameraDefects.preset(CameraPreset.REALISTIC)
    assert not realistic.ideal and realistic.read_noise_e > 0 and realistic.motion_samples > 1


@pytest.mark.parametrize("sigma", [0.6, 2.0])
def test_gaussian_blur_is_the_separable_convolution_with_mirrored_borders(sigma):
    rng = np.random.default_rng(4)
    image = rng.random((12, 17, 3))
    kernel = gaussian_kernel(sigma)
    reach = len(kernel) // 2
    padded = np.pad(image, ((reach, reach), (reach, reach), (0, 0)), mode="reflect")
    want = np.zeros_like(image)
    for i in range(image.shape[0]):
        for j in range(image.shape[1]):
            window = padded[i : i + 2 * reach + 1, j : j + 2 * reach + 1]
            want[i, j] = np.einsum("a,b,abc->c", kernel, kernel, window)
    np.testing.assert_allclose(gaussian_blur(image, sigma), want, rtol=1e-12, atol=1e-14)
