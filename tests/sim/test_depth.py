"""The renderer's numpy depth path (flylog.sim.depth) against its compiled kernel: equal bit
for bit (depth and ids), pose by pose and in batches, on the fixture scenes and on scenes whose
footprints overlap along a ray (the columns the run assembly hands to the reference)."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from flylog.geometry import Pose2D, StereoRig
from flylog.metrics.view import TrueViews, block_rig
from flylog.scene import load_scene, parse_scene
from flylog.sim.depth import depths_reference, true_depths
from flylog.sim.render import Renderer

SCENES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
SMALL = StereoRig(width=64, height=48, focal_px=50.0, baseline=0.12, mount_height=0.5)
# Odd sizes: a row (and a column) through the optical centre, slope 0 (the horizon itself).
ODD = StereoRig(width=63, height=47, focal_px=40.0, baseline=0.12, mount_height=1.3)
IMPLS = {"runs": true_depths, "reference": depths_reference}

# Two boxes overlapping on the ground, a cylinder inside a low box, a wall through a box
# and a tall box the camera stands inside of at the origin (its faces seen from within).
OVERLAPS = """
name = "overlaps"
[[obstacles]]
kind = "box"
center = [3.0, 0.0]
size = [1.0, 1.0]
height = 0.3
[[obstacles]]
kind = "box"
center = [3.4, 0.3]
size = [1.0, 0.6]
height = 1.0
yaw_deg = 30.0
[[obstacles]]
kind = "box"
center = [2.5, -2.0]
size = [1.2, 1.2]
height = 0.2
[[obstacles]]
kind = "cylinder"
center = [2.5, -2.0]
radius = 0.3
height = 0.9
[[obstacles]]
kind = "wall"
start = [5.0, -4.0]
end = [5.0, 4.0]
height = 0.4
[[obstacles]]
kind = "box"
center = [5.0, 1.0]
size = [0.5, 0.5]
height = 2.0
"""


def _poses(rng: np.random.Generator, n: int, spread: float) -> np.ndarray:
    """(n, 3) poses scattered around the origin, any heading."""
    xy = rng.uniform(-spread, spread, (n, 2))
    return np.column_stack([xy, rng.uniform(-np.pi, np.pi, n)])


def _kernel(scene, rig, poses):
    renderer = Renderer(scene, rig)
    views = [renderer.render_depth(Pose2D(*p)) for p in poses]
    return np.stack([d for d, _ in views]), np.stack([i for _, i in views])


def _assert_same(got, want):
    depth, ids = got
    assert depth.dtype == np.float32 and ids.dtype == np.int16
    assert np.array_equal(ids, want[1])
    assert np.array_equal(depth, want[0])  # inf (sky) equal to inf; no NaN anywhere


@pytest.mark.parametrize("impl", IMPLS)
@pytest.mark.parametrize("rig", [SMALL, ODD], ids=["even", "odd"])
@pytest.mark.parametrize("name", ["clutter", "corridor", "near-obstacle", "turn"])
def test_depths_equal_the_kernels_on_the_fixture_scenes(impl, rig, name):
    scene = load_scene(SCENES / f"{name}.toml")
    poses = np.vstack([[0.0, 0.0, 0.0], _poses(np.random.default_rng(5), 11, 4.0)])
    want = _kernel(scene, rig, poses)
    _assert_same(IMPLS[impl](scene.footprints, rig, poses), want)
    assert (want[1] >= 0).any() and (want[1] == -1).any() and (want[1] == -2).any()


@pytest.mark.parametrize("impl", IMPLS)
def test_overlapping_footprints_and_a_camera_inside_one(impl):
    scene = parse_scene(OVERLAPS, "overlaps")
    rng = np.random.default_rng(7)
    poses = np.vstack([[0.0, 0.0, 0.0], [4.9, 0.9, 0.3], _poses(rng, 14, 3.0)])
    want = _kernel(scene, SMALL, poses)
    _assert_same(IMPLS[impl](scene.footprints, SMALL, poses), want)
    assert len(np.unique(want[1])) >= 5  # the view is not trivial


def test_coarse_rig_of_the_reference_camera_and_batches():
    """The metrics' own case: 640x480 in 4x4 blocks, views rendered in batches."""
    scene = load_scene(SCENES / "corridor.toml")
    rig = block_rig(StereoRig(), 4)
    poses = _poses(np.random.default_rng(3), 37, 3.0)
    want = _kernel(scene, rig, poses)
    _assert_same(TrueViews(scene, StereoRig(), 160).render(poses), want)
    one = TrueViews(scene, StereoRig(), 160).view(Pose2D(*poses[5]))
    assert one.block == 4
    assert np.array_equal(one.depth, want[0][5]) and np.array_equal(one.ids, want[1][5])


def test_empty_scene_and_no_poses():
    scene = parse_scene('name = "empty"', "empty")
    rig = dataclasses.replace(SMALL, width=20, height=15)
    poses = np.array([[1.0, 2.0, 0.5]])
    want = _kernel(scene, rig, poses)
    _assert_same(true_depths(scene.footprints, rig, poses), want)
    assert set(np.unique(want[1])) == {-1, -2}
    depth, ids = true_depths(scene.footprints, rig, np.empty((0, 3)))
    assert depth.shape == ids.shape == (0, 15, 20)
