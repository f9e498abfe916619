import math
from dataclasses import dataclass

import numpy as np
import pytest

from flylog.config import from_mapping, param, to_mapping
from flylog.errors import ConfigError
from flylog.geometry import Pose2D, StereoRig, compose, inverse, relative, transform_points_2d


def test_compose_inverse_is_identity():
    a = Pose2D(1.0, -2.0, 0.7)
    ident = compose(a, inverse(a))
    assert ident.x == pytest.approx(0.0, abs=1e-12)
    assert ident.y == pytest.approx(0.0, abs=1e-12)
    assert ident.theta == pytest.approx(0.0, abs=1e-12)


def test_relative_recovers_motion():
    a = Pose2D(0.5, 0.2, 1.0)
    step = Pose2D(0.1, 0.0, -math.radians(1.0))
    b = compose(a, step)
    got = relative(a, b)
    assert (got.x, got.y, got.theta) == pytest.approx((step.x, step.y, step.theta))


def test_transform_points_matches_compose():
    pose = Pose2D(2.0, 1.0, math.pi / 2)
    pts = np.array([[1.0, 0.0, 0.3]])
    out = transform_points_2d(pose, pts)
    assert out[0] == pytest.approx([2.0, 2.0, 0.3])


def test_project_backproject_round_trip():
    rig = StereoRig(width=320, height=240, focal_px=250.0, baseline=0.1, mount_height=0.4)
    rng = np.random.default_rng(0)
    u = rng.uniform(0, rig.width - 1, 100)
    v = rng.uniform(0, rig.height - 1, 100)
    z = rng.uniform(0.5, 20.0, 100)
    xyz = rig.backproject(u, v, z)
    ul, ur, vv, depth = rig.project(xyz)
    np.testing.assert_allclose(ul, u, atol=1e-9)
    np.testing.assert_allclose(vv, v, atol=1e-9)
    np.testing.assert_allclose(depth, z, atol=1e-12)
    np.testing.assert_allclose(ul - ur, rig.disparity(z), rtol=1e-12)


def test_known_geometry_point_straight_ahead_of_left_camera():
    rig = StereoRig(width=641, height=481, focal_px=500.0, baseline=0.2, mount_height=0.5)
    # A point 2 m in front of the left camera, at its height: the left principal point,
    # and disparity f·b/Z = 50 px.
    ul, ur, v, depth = rig.project(np.array([[rig.mount_x + 2.0, 0.1, 0.5]]))
    assert (ul[0], v[0], depth[0]) == pytest.approx((320.0, 240.0, 2.0))
    assert ul[0] - ur[0] == pytest.approx(50.0)


def test_right_projection_matrix_carries_baseline():
    rig = StereoRig(focal_px=400.0, baseline=0.15)
    assert rig.projection("right")[0, 3] == pytest.approx(-60.0)
    assert rig.projection("left")[0, 3] == 0.0


@dataclass(frozen=True)
class _Inner:
    size: float = param(1.0, help="size", unit="m", min=0.0)


@dataclass(frozen=True)
class _Outer:
    count: int = param(3, help="count", min=1)
    name: str = param("x", help="name")
    inner: _Inner = param(_Inner(), help="inner")
    values: tuple[float, ...] = param((1.0, 2.0), help="values")


def test_config_round_trip_and_defaults():
    cfg = from_mapping(_Outer, {"count": 4, "inner": {"size": 2}}, source="a.toml")
    assert cfg == _Outer(count=4, inner=_Inner(2.0))
    assert from_mapping(_Outer, to_mapping(cfg), source="x") == cfg


@pytest.mark.parametrize(
    ("data", "needle"),
    [
        ({"count": "three"}, "a.toml: field 'count': expected an integer, got 'three'"),
        ({"count": 0}, "a.toml: field 'count': must be at least 1"),
        ({"inner": {"size": -1}}, "a.toml: field 'inner.size': must be at least 0.0 m"),
        ({"inner": {"colour": 1}}, "a.toml: unknown field 'inner.colour'"),
        ({"values": [1, "a"]}, "a.toml: field 'values[1]': expected a number"),
    ],
)
def test_config_errors_name_file_and_field(data, needle):
    with pytest.raises(ConfigError) as info:
        from_mapping(_Outer, data, source="a.toml")
    assert needle in str(info.value)
