from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from flylog.geometry import Pose2D, StereoRig
from flylog.scene import load_scene, parse_scene
from flylog.sim.render import GROUND, SKY, Renderer
from tests.sim.render_reference import render_bands_reference, render_reference

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
SMALL = StereoRig(width=64, height=48, focal_px=50.0, baseline=0.12, mount_height=0.5)


def render_with(impl, scene, rig, pose):
    if impl == "numba":
        return Renderer(scene, rig).render(pose)
    return render_reference(scene, rig, pose)


IMPLS = ["numba", "numpy"]


def wall_scene(x, *, height=10.0, low_texture=False, feature_size=0.02):
    # Lit from behind the cameras (the -x side), so that the wall's face is not in shade.
    return parse_scene(
        f"""
name = "wall"
[lighting]
azimuth_deg = 180.0
[[obstacles]]
kind = "wall"
start = [{x}, -50.0]
end = [{x}, 50.0]
thickness = 0.2
height = {height}
low_texture = {str(low_texture).lower()}
texture = {{ feature_size = {feature_size}, contrast = 0.8 }}
""",
        "mem",
    )


@pytest.mark.parametrize(
    ("name", "pose"),
    [
        ("clutter", Pose2D(0.0, 0.0, 0.0)),
        ("clutter", Pose2D(3.0, -1.0, 0.7)),
        ("corridor", Pose2D(2.0, 0.3, -0.2)),
        ("turn", Pose2D(0.0, 0.0, -1.0)),
    ],
)
def test_numba_renderer_matches_numpy_reference(name, pose):
    scene = load_scene(FIXTURES / f"{name}.toml")
    got = Renderer(scene, SMALL).render(pose)
    ref = render_reference(scene, SMALL, pose)
    assert np.array_equal(got.ids, ref.ids)
    assert np.array_equal(np.isinf(got.depth), np.isinf(ref.depth))
    finite = np.isfinite(ref.depth)
    np.testing.assert_allclose(got.depth[finite], ref.depth[finite], rtol=1e-6)
    for a, b in ((got.left, ref.left), (got.right, ref.right)):
        assert np.abs(a.astype(int) - b.astype(int)).max() <= 1
    assert len(np.unique(got.ids)) > 3  # the view is not trivial


@pytest.mark.parametrize("impl", IMPLS)
def test_wall_at_known_distance_and_ground_below_it(impl):
    scene = wall_scene(5.0)
    out = render_with(impl, scene, SMALL, Pose2D())
    wall_depth = 5.0 - 0.1 - SMALL.mount_x  # front face minus the cameras' forward offset
    v = np.arange(SMALL.height)[:, None] * np.ones((1, SMALL.width))
    with np.errstate(divide="ignore"):
        ground = SMALL.mount_height * SMALL.focal_px / (v - SMALL.cy)
    sees_ground = (v > SMALL.cy) & (ground < wall_depth)
    assert np.array_equal(out.ids == GROUND, sees_ground)
    assert np.all(out.ids[~sees_ground] == 0)
    np.testing.assert_allclose(out.depth[~sees_ground], wall_depth, rtol=1e-6)
    np.testing.assert_allclose(out.depth[sees_ground], ground[sees_ground], rtol=1e-6)


@pytest.mark.parametrize("impl", IMPLS)
def test_empty_scene_is_ground_below_the_horizon_and_sky_above(impl):
    scene = parse_scene('name = "empty"\n', "mem")
    out = render_with(impl, scene, SMALL, Pose2D(1.0, 2.0, 0.3))
    v = np.arange(SMALL.height)
    below = v > SMALL.cy
    assert np.all(out.ids[~below] == SKY) and np.all(np.isinf(out.depth[~below]))
    assert np.all(out.ids[below] == GROUND)
    expect = SMALL.mount_height * SMALL.focal_px / (v[below] - SMALL.cy)
    np.testing.assert_allclose(out.depth[below], np.repeat(expect[:, None], SMALL.width, 1))
    # The sky is textured by direction only: the same pixels in both cameras (zero
    # disparity, as at infinity), and not plain.
    np.testing.assert_array_equal(out.left[~below], out.right[~below])
    assert out.left[~below].std() > 2.0
    plain = parse_scene('name = "plain"\n[lighting]\nsky_contrast = 0.0\n', "mem")
    sky = render_with(impl, plain, SMALL, Pose2D(1.0, 2.0, 0.3)).left[~below].reshape(-1, 3)
    assert np.all(sky == sky[0])


@pytest.mark.parametrize("impl", IMPLS)
def test_disparity_of_fronto_parallel_wall_is_f_b_over_z(impl):
    rig = StereoRig(width=96, height=64, focal_px=60.0, baseline=0.2, mount_height=0.5)
    depth = 1.2  # f·b/Z = 10 px exactly
    shift = round(rig.focal_px * rig.baseline / depth)
    scene = wall_scene(depth + rig.mount_x + 0.1)
    out = render_with(impl, scene, rig, Pose2D())
    rows = np.all(out.ids == 0, axis=1)
    assert rows.sum() > 20
    left = out.left[rows].astype(int)
    right = out.right[rows].astype(int)

    def mismatch(d):
        return np.abs(left[:, d:] - right[:, : rig.width - d]).mean()

    assert np.abs(left[:, shift:] - right[:, : rig.width - shift]).max() <= 1
    assert mismatch(shift) < 0.01
    assert min(mismatch(shift - 2), mismatch(shift + 2)) > 5.0


@pytest.mark.parametrize("impl", IMPLS)
def test_low_texture_wall_is_nearly_uniform(impl):
    textured = render_with(impl, wall_scene(3.0, feature_size=0.2), SMALL, Pose2D())
    plain = render_with(impl, wall_scene(3.0, low_texture=True, feature_size=0.2), SMALL, Pose2D())
    on_wall = textured.ids == 0
    assert textured.left[on_wall].std(axis=0).min() > 5.0
    assert plain.left[on_wall].std(axis=0).max() < 1.0


@pytest.mark.parametrize("impl", IMPLS)
def test_top_face_and_obstacle_ids(impl):
    scene = parse_scene(
        """
name = "tops"
[[obstacles]]
kind = "box"          # a low platform ahead: seen from above
center = [4.0, 0.0]
size = [4.0, 20.0]
height = 0.2
[[obstacles]]
kind = "cylinder"     # a post to the left
center = [1.5, 1.0]
radius = 0.2
height = 3.0
""",
        "mem",
    )
    out = render_with(impl, scene, SMALL, Pose2D())
    v = np.arange(SMALL.height)[:, None] * np.ones((1, SMALL.width))
    slope = (v - SMALL.cy) / SMALL.focal_px
    with np.errstate(divide="ignore"):
        t_top = (SMALL.mount_height - 0.2) / slope
    front, back = 2.0 - SMALL.mount_x, 6.0 - SMALL.mount_x
    on_top = (out.ids == 0) & (slope > 0) & (t_top >= front) & (t_top <= back)
    assert on_top.sum() > 50
    np.testing.assert_allclose(out.depth[on_top], t_top[on_top], rtol=1e-6)
    # The post is left of centre: its pixels are in the left half of the image.
    u = np.nonzero(out.ids == 1)[1]
    assert len(u) > 20 and u.max() < SMALL.cx
    # Robot turned left by 90°: the post (now to the right) is out of view.
    turned = render_with(impl, scene, SMALL, Pose2D(0.0, 0.0, np.pi / 2))
    assert not np.any(turned.ids == 1)


def _rolling_bands(pose, rows_per_band, height):
    """Bands of ``rows_per_band`` rows, each from ``pose`` turned by 0.01 rad more."""
    return [
        (
            Pose2D(pose.x + 0.02 * i, pose.y, pose.theta + 0.01 * i),
            first,
            min(first + rows_per_band, height),
        )
        for i, first in enumerate(range(0, height, rows_per_band))
    ]


@pytest.mark.parametrize("rows_per_band", [1, 7, 48])
def test_numba_bands_match_the_numpy_reference_row_for_row(rows_per_band):
    scene = load_scene(FIXTURES / "clutter.toml")
    bands = _rolling_bands(Pose2D(1.0, -0.5, 0.3), rows_per_band, SMALL.height)
    got = Renderer(scene, SMALL).render_bands(bands)
    ref = render_bands_reference(scene, SMALL, bands)
    assert np.array_equal(got.ids, ref.ids)
    finite = np.isfinite(ref.depth)
    assert np.array_equal(np.isfinite(got.depth), finite)
    np.testing.assert_allclose(got.depth[finite], ref.depth[finite], rtol=1e-6)
    for a, b in ((got.left, ref.left), (got.right, ref.right)):
        assert np.abs(a.astype(int) - b.astype(int)).max() <= 1


@pytest.mark.parametrize(
    "rig", [SMALL, replace(SMALL, tilt=8.0, roll=3.0)], ids=["level", "tilted"]
)
@pytest.mark.parametrize("name", ["clutter", "corridor"])
def test_a_band_is_bit_for_bit_the_rows_of_its_poses_whole_frame(name, rig):
    # A row's pixels depend on its own pose only: a frame rendered in bands from one pose is
    # the frame of that pose, and each band of a rolling frame is its pose's frame's rows.
    scene = load_scene(FIXTURES / f"{name}.toml")
    renderer = Renderer(scene, rig)
    pose = Pose2D(2.0, 0.3, -0.2)
    whole = renderer.render(pose)
    bands = [(pose, first, min(first + 5, rig.height)) for first in range(0, rig.height, 5)]
    for got in (renderer.render_bands(bands), renderer.render_bands(bands[::-1])):
        for key in ("left", "right", "depth", "ids"):
            assert np.array_equal(getattr(got, key), getattr(whole, key))
    rolling = _rolling_bands(pose, 5, rig.height)
    got = renderer.render_bands(rolling)
    for band_pose, first, stop in rolling:
        own = renderer.render(band_pose)
        for key in ("left", "right", "depth", "ids"):
            assert np.array_equal(getattr(got, key)[first:stop], getattr(own, key)[first:stop])


def test_render_depth_matches_render():
    scene = load_scene(FIXTURES / "near-obstacle.toml")
    renderer = Renderer(scene, SMALL)
    pose = Pose2D(0.1, 0.0, 0.05)
    full = renderer.render(pose)
    depth, ids = renderer.render_depth(pose)
    assert np.array_equal(depth, full.depth) and np.array_equal(ids, full.ids)
    assert depth.dtype == np.float32 and ids.dtype == np.int16
    assert full.left.shape == (SMALL.height, SMALL.width, 3) and full.left.dtype == np.uint8


@pytest.mark.parametrize("impl", IMPLS)
def test_a_wall_seen_at_a_grazing_angle_looks_the_same_to_both_cameras(impl):
    # A wall beside the robot, running along its view: far along it, a pixel covers many
    # times the texture's finest octave. Point-sampling those octaves would alias them into
    # noise that differs between the two cameras; faded by the pixel's footprint on the face,
    # a surface point has the same colour in both images, and texture is left to match.
    scene = parse_scene(
        """
name = "side wall"
[[obstacles]]
kind = "wall"
start = [-5.0, 1.5]
end = [60.0, 1.5]
height = 1.2
texture = { feature_size = 0.04, contrast = 0.6 }
""",
        "mem",
    )
    rig = StereoRig(width=160, height=120, focal_px=125.0)
    out = render_with(impl, scene, rig, Pose2D())
    v, u = np.nonzero((out.ids == 0) & (out.depth > 4.0))
    assert len(v) > 500
    z = out.depth[v, u].astype(float)
    u_right = np.floor(u - rig.focal_px * rig.baseline / z + 0.5).astype(int)
    left = out.left[v, u].astype(float)
    right = out.right[v, u_right].astype(float)
    # measured 0.35 grey levels (1.76 when the footprint ignored the incidence); texture
    # standard deviation 14
    assert np.abs(left - right).mean() < 0.7
    assert left.std() > 8.0
