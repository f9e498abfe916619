"""The real camera's rig: principal point, doffs and a full mount pose."""

import dataclasses
import math

import numpy as np
import pytest

from flylog.config import from_mapping, to_mapping
from flylog.geometry import StereoRig
from flylog.geometry.stereo import (
    OPTICAL_IN_BASE_QUAT,
    OPTICAL_TO_BASE,
    mount_angles,
    quaternion_matrix,
)

REAL = StereoRig(
    width=320,
    height=240,
    focal_px=260.0,
    baseline=0.2,
    principal_point=(150.25, 131.5),
    doffs=7.25,
    tilt=25.0,
    roll=-3.0,
    pan=10.0,
    mount_x=0.3,
    mount_y=-0.04,
    mount_height=0.9,
)


def _level_formulas(rig, xyz):
    """The horizontal rig's shortcut formulas (cameras at (mount_x, ±B/2, mount_height))."""
    depth = xyz[:, 0] - rig.mount_x
    safe = np.where(depth > 1e-9, depth, 1e-9)
    f, hb = rig.focal_px, rig.baseline / 2.0
    u_left = rig.cx - f * (xyz[:, 1] - hb) / safe
    u_right = rig.cx - f * (xyz[:, 1] + hb) / safe
    v = rig.cy - f * (xyz[:, 2] - rig.mount_height) / safe
    return u_left, u_right, v, depth


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_the_default_rig_projects_bit_for_bit_as_the_level_formulas(dtype):
    rig = StereoRig(width=160, height=120, focal_px=125.0)
    rng = np.random.default_rng(0)
    xyz = rng.uniform([-1.0, -4.0, -1.0], [20.0, 4.0, 3.0], (5000, 3)).astype(dtype)
    xyz[::50, 1] = rig.baseline / 2.0  # exactly in front of the left camera
    for got, want in zip(rig.project(xyz), _level_formulas(rig, xyz), strict=True):
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)
    u, v, d = rng.uniform(0, 160, 100), rng.uniform(0, 120, 100), rng.uniform(0.2, 9, 100)
    back = rig.backproject(u, v, d)
    np.testing.assert_array_equal(back[:, 0], rig.mount_x + d)
    np.testing.assert_array_equal(back[:, 1], rig.baseline / 2.0 - (u - rig.cx) * d / rig.focal_px)
    np.testing.assert_array_equal(back[:, 2], rig.mount_height - (v - rig.cy) * d / rig.focal_px)
    assert rig.is_level and rig.mount_quaternion() == OPTICAL_IN_BASE_QUAT
    np.testing.assert_array_equal(rig.rotation(), OPTICAL_TO_BASE)
    assert (rig.cx, rig.cy, rig.cx_right) == (79.5, 59.5, 79.5)


def test_project_and_backproject_are_inverse_on_a_real_rig():
    rng = np.random.default_rng(1)
    u, v = rng.uniform(0, 320, 500), rng.uniform(0, 240, 500)
    depth = rng.uniform(0.3, 30.0, 500)
    xyz = REAL.backproject(u, v, depth)
    ul, ur, vv, d = REAL.project(xyz)
    np.testing.assert_allclose(ul, u, atol=1e-9)
    np.testing.assert_allclose(vv, v, atol=1e-9)
    np.testing.assert_allclose(d, depth, rtol=1e-12)
    # Middlebury's convention: disparity = f·B/Z − doffs
    np.testing.assert_allclose(ul - ur, REAL.focal_px * REAL.baseline / depth - REAL.doffs)
    np.testing.assert_allclose(REAL.depth_of_disparity(ul - ur), depth, rtol=1e-9)
    np.testing.assert_allclose(REAL.disparity(depth), ul - ur, atol=1e-9)


def test_a_camera_tilted_down_sees_the_horizon_above_its_centre_and_its_feet_below():
    rig = StereoRig(tilt=20.0)
    far = np.array([[1000.0, 0.06, rig.mount_height]])  # at the cameras' height, far ahead
    _, _, v, _ = rig.project(far)
    assert v[0] == pytest.approx(rig.cy - rig.focal_px * math.tan(math.radians(20.0)), abs=0.05)
    # the ground point on the optical axis: mount_height / tan(20°) ahead
    ahead = rig.mount_x + rig.mount_height / math.tan(math.radians(20.0))
    u, _, v, depth = rig.project(np.array([[ahead, 0.06, 0.0]]))
    assert (u[0], v[0]) == pytest.approx((rig.cx, rig.cy), abs=1e-9)
    assert depth[0] == pytest.approx(rig.mount_height / math.sin(math.radians(20.0)))


def test_roll_lowers_the_right_camera_and_pan_turns_left():
    rolled = StereoRig(roll=10.0)
    assert (
        rolled.camera_position("right")[2] < rolled.mount_height < rolled.camera_position("left")[2]
    )
    panned = StereoRig(pan=30.0)
    axis = panned.rotation()[:, 2]  # the optical axis in base_link
    assert axis == pytest.approx([math.cos(math.radians(30)), math.sin(math.radians(30)), 0.0])
    left, right = (np.array(panned.camera_position(s)) for s in ("left", "right"))
    assert np.linalg.norm(left - right) == pytest.approx(panned.baseline)


def test_mount_angles_invert_the_rotation_and_the_quaternion_is_the_same_rotation():
    r = REAL.rotation()
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(quaternion_matrix(REAL.mount_quaternion()), r, atol=1e-15)
    assert mount_angles(r) == pytest.approx((REAL.pan, REAL.tilt, REAL.roll))
    assert mount_angles(OPTICAL_TO_BASE) == (0.0, -0.0, 0.0)


def test_the_calibration_matrices_carry_principal_points_and_baseline():
    k_left, p_right = REAL.intrinsics("left"), REAL.projection("right")
    assert (k_left[0, 2], k_left[1, 2]) == (150.25, 131.5)
    assert p_right[0, 2] - k_left[0, 2] == REAL.doffs
    assert -p_right[0, 3] / p_right[0, 0] == pytest.approx(REAL.baseline)


def test_resizing_scales_principal_point_and_doffs_about_pixel_centres():
    half = REAL.resized(160, 120)
    assert half.focal_px == 130.0 and half.doffs == pytest.approx(3.625)
    assert half.principal_point == pytest.approx((74.875, 65.5))
    # the same ray lands on the same continuous image position
    xyz = REAL.backproject(np.array([10.0]), np.array([200.0]), np.array([4.0]))
    u, _, v, _ = half.project(xyz)
    assert ((u[0] + 0.5) * 2 - 0.5, (v[0] + 0.5) * 2 - 0.5) == pytest.approx((10.0, 200.0))
    assert StereoRig().resized(320, 240) == dataclasses.replace(
        StereoRig(), width=320, height=240, focal_px=250.0
    )


def test_the_rig_round_trips_through_its_mapping():
    assert from_mapping(StereoRig, to_mapping(REAL), source="t") == REAL
    assert from_mapping(StereoRig, to_mapping(StereoRig()), source="t") == StereoRig()
