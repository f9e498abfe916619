"""Tilted, rolled and panned cameras rendered through level ones (flylog.sim.rotated)."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from flylog.errors import ConfigError
from flylog.geometry import Pose2D, StereoRig
from flylog.metrics.view import TrueViews
from flylog.scene import load_scene
from flylog.sim.depth import true_depths
from flylog.sim.render import GROUND, SKY, Renderer
from flylog.sim.rotated import warps

SCENES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
RIG = StereoRig(width=96, height=72, focal_px=75.0)
POSE = Pose2D(0.4, 0.1, 0.05)


@pytest.fixture(scope="module")
def corridor():
    return load_scene(SCENES / "corridor.toml")


@pytest.mark.parametrize(
    "mount", [dict(tilt=15.0), dict(tilt=28.0, roll=4.0), dict(roll=-6.0, pan=8.0)]
)
def test_ground_pixels_back_project_onto_the_ground(corridor, mount):
    rig = dataclasses.replace(RIG, principal_point=(50.25, 30.5), doffs=2.0, **mount)
    depth, ids = Renderer(corridor, rig).render_depth(POSE)
    v, u = np.nonzero(ids == GROUND)
    assert len(u) > 0.2 * rig.n_pixels
    z = rig.backproject(u.astype(float), v.astype(float), depth[v, u].astype(float))[:, 2]
    # inverse depth interpolated within one surface: exact on a plane, up to float32; the
    # nearest level pixel's depth only next to another surface
    off = np.abs(z) >= 1e-4
    assert np.mean(off) < 0.03
    padded = np.pad(ids != GROUND, 1, constant_values=True)
    edge = np.zeros_like(ids, dtype=bool)
    for dv in range(3):
        for du in range(3):
            edge |= padded[dv : dv + ids.shape[0], du : du + ids.shape[1]]
    assert edge[v[off], u[off]].all()


def test_the_metrics_depth_path_equals_the_renderer_on_a_rotated_rig(corridor):
    rig = dataclasses.replace(RIG, tilt=12.0, roll=2.0)
    renderer = Renderer(corridor, rig)
    poses = np.array([[0.4, 0.1, 0.05], [2.0, -0.3, -0.2]])
    depth, ids = true_depths(corridor.footprints, rig, poses)
    for b, (x, y, theta) in enumerate(poses):
        want_depth, want_ids = renderer.render_depth(Pose2D(x, y, theta))
        np.testing.assert_array_equal(depth[b], want_depth)
        np.testing.assert_array_equal(ids[b], want_ids)
        np.testing.assert_array_equal(renderer.render(Pose2D(x, y, theta)).depth, want_depth)
    view = TrueViews(corridor, rig, min_width=48).view(POSE)  # blocks of 2 px
    assert view.depth.shape == (36, 48) and view.block == 2


def test_a_camera_turned_by_almost_nothing_renders_the_level_images(corridor):
    level = Renderer(corridor, RIG).render(POSE)
    turned = Renderer(corridor, dataclasses.replace(RIG, tilt=1e-9)).render(POSE)
    for a, b in ((level.left, turned.left), (level.right, turned.right)):
        assert np.abs(a.astype(int) - b.astype(int)).max() <= 1
    np.testing.assert_array_equal(level.ids, turned.ids)
    finite = np.isfinite(level.depth)
    np.testing.assert_array_equal(finite, np.isfinite(turned.depth))
    np.testing.assert_allclose(turned.depth[finite], level.depth[finite], rtol=1e-5)


def test_tilting_down_shows_more_ground_and_less_sky(corridor):
    shares = []
    for tilt in (-10.0, 0.0, 20.0):
        _, ids = Renderer(corridor, dataclasses.replace(RIG, tilt=tilt)).render_depth(POSE)
        shares.append((np.mean(ids == GROUND), np.mean(ids == SKY)))
    ground, sky = zip(*shares, strict=True)
    assert ground[0] < ground[1] < ground[2] and sky[0] > sky[1] > sky[2]


def test_a_view_too_far_from_the_forward_axis_is_refused():
    with pytest.raises(ConfigError, match="80°"):
        warps(dataclasses.replace(RIG, pan=80.0))


def test_the_nearest_visible_obstacle_of_a_rotated_view_matches_the_level_shortcut(corridor):
    from flylog.metrics.flies import _nearest_visible

    poses = np.array([[0.4, 0.1, 0.05], [3.0, -0.2, 0.3]])
    turned = dataclasses.replace(RIG, tilt=1e-9)
    near = []
    for rig in (RIG, turned):
        depth, ids = true_depths(corridor.footprints, rig, poses)
        near.append(_nearest_visible(depth, ids, rig, 1))
    assert np.all(np.isfinite(near[0]))
    np.testing.assert_allclose(near[1], near[0], rtol=1e-4)
