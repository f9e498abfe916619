"""The visual heading compares patches with the engine's measure (engine.similarity): the
compiled dissimilarity against its numpy reference, the scans against each other, and a
gain between the keyframe and the later pair."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from flylog.fly.config import Similarity
from flylog.fly.heading import (
    HeadingConfig,
    comparable_flies,
    measure_yaw,
    patch_dissimilarity,
    patch_dissimilarity_numpy,
    yaw_scores_numba,
    yaw_scores_numpy,
)
from flylog.fly.measures import measure_of
from flylog.geometry import Pose2D, compose
from flylog.scene.load import load_scene
from flylog.sim.render import Renderer

SCENES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
TURN = 0.5 / 15  # rad: one frame period (15 Hz) turning on the spot at 0.5 rad/s


@pytest.fixture(scope="module")
def corridor():
    """The corridor at 320×240 (focal 250 px), its start view and 2000 points on its
    surfaces under continuous pixel positions."""
    scene = load_scene(SCENES / "corridor.toml")
    rig = dataclasses.replace(scene.spec.camera, width=320, height=240, focal_px=250.0)
    renderer = Renderer(scene, rig)
    first = renderer.render(scene.start_pose)
    rng = np.random.default_rng(0)
    u, v = rng.uniform(4, rig.width - 4, 2000), rng.uniform(4, rig.height - 4, 2000)
    depth = first.depth[np.round(v).astype(int), np.round(u).astype(int)].astype(float)
    seen = np.isfinite(depth)
    return rig, renderer, scene.start_pose, first, rig.backproject(u[seen], v[seen], depth[seen])


@pytest.mark.parametrize("similarity", list(Similarity))
@pytest.mark.parametrize("channels", [1, 3])
def test_compiled_dissimilarity_equals_numpy_reference_bit_for_bit(similarity, channels):
    rng = np.random.default_rng(channels)
    a = rng.uniform(0, 255, (200, 49 * channels))
    b = rng.uniform(0, 255, (200, 49 * channels))
    b[:20] = 100.0  # flat patches
    a[20:40] = 37.5
    measure = measure_of(similarity)
    want = patch_dissimilarity_numpy(a, b, channels, measure)
    got = np.array([patch_dissimilarity(a[i], b[i], channels, 49, measure) for i in range(len(a))])
    np.testing.assert_array_equal(got, want)
    assert np.isfinite(want).all() and (want >= 0).all()


@pytest.mark.parametrize("similarity", list(Similarity))
def test_numba_and_numpy_scans_agree_for_every_measure(corridor, similarity):
    rig, renderer, start, first, points = corridor
    increment = Pose2D(0.01, 0.0, TURN)
    after = renderer.render(compose(compose(start, increment), Pose2D(0.0, 0.0, 0.4 / 250)))
    offsets = HeadingConfig().offsets(rig.focal_px)
    chosen = points[comparable_flies(points, increment, rig, offsets, 7)][:300]
    pairs = (first.left, first.right), (after.left, after.right)
    args = (*pairs, chosen, increment, rig, offsets, 7, 1.0, similarity)
    np.testing.assert_allclose(yaw_scores_numba(*args), yaw_scores_numpy(*args), rtol=1e-12)


def test_zssd_is_the_scans_default():
    rng = np.random.default_rng(3)
    a, b = rng.uniform(0, 255, (2, 30, 147))
    zssd = patch_dissimilarity_numpy(a, b, 3, measure_of(Similarity.ZSSD))
    d = (a - b).reshape(30, 49, 3)
    plain = ((d - d.mean(axis=1, keepdims=True)) ** 2).sum(axis=(1, 2))
    np.testing.assert_allclose(zssd, plain, rtol=1e-9)


@pytest.mark.parametrize(
    "similarity", [Similarity.ZNCC, Similarity.GAIN_ZSSD, Similarity.CONTRAST_ZNCC]
)
def test_gain_invariant_measures_ignore_a_gain_of_the_later_patch(similarity):
    rng = np.random.default_rng(5)
    a, b = rng.uniform(0, 120, (2, 50, 147))
    measure = measure_of(similarity)
    plain = patch_dissimilarity_numpy(a, b, 3, measure)
    brighter = patch_dissimilarity_numpy(a, 2.0 * b + 1.0, 3, measure)
    np.testing.assert_allclose(brighter, plain, rtol=1e-9)


def test_zncc_measures_the_turn_when_the_later_pair_is_brighter(corridor):
    rig, renderer, start, first, points = corridor
    increment, error_px = Pose2D(0.0, 0.0, TURN), 0.6
    after = renderer.render(compose(compose(start, increment), Pose2D(0.0, 0.0, error_px / 250)))
    bright = [
        np.clip(1.25 * a.astype(float), 0, 255).astype(np.uint8) for a in (after.left, after.right)
    ]
    pairs = (first.left, first.right), tuple(bright)
    found = measure_yaw(*pairs, points, increment, rig, HeadingConfig(), similarity=Similarity.ZNCC)
    assert found.yaw is not None
    assert found.yaw * rig.focal_px == pytest.approx(error_px, abs=0.1)
