"""Every encoder through write → read gives back exactly what went in."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flylog.geometry import OPTICAL_IN_BASE_QUAT, Pose2D
from flylog.geometry.stereo import OPTICAL_TO_BASE
from flylog.io import LogWriter, contract, encode, open_log
from flylog.sensors import OdomReading, SonarReading

from .conftest import RIG, SONAR, Sample, write_sample


def by_topic(sample: Sample) -> dict[str, list]:
    out: dict[str, list] = {}
    for m in open_log(sample.path).messages():
        out.setdefault(m.topic, []).append(m)
    return out


@pytest.fixture(scope="module", params=["zstd", "lz4", "none"])
def read_back(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory):
    path = tmp_path_factory.mktemp(request.param) / "log.mcap"
    sample = write_sample(path, compression=request.param)
    return sample, by_topic(sample)


def test_every_topic_reads_back_with_its_count(read_back):
    sample, got = read_back
    assert set(got) == set(sample.written) == set(contract.TOPIC_SCHEMAS)
    for topic, msgs in got.items():
        assert [m.log_time_ns for m in msgs] == [t for t, _ in sample.written[topic]], topic
        assert {m.schema for m in msgs} == {contract.TOPIC_SCHEMAS[topic]}


def test_images_round_trip_exactly(read_back):
    sample, got = read_back
    for topic in (contract.LEFT_IMAGE, contract.RIGHT_IMAGE):
        for m, (_, image) in zip(got[topic], sample.written[topic], strict=True):
            assert m.value.dtype == np.uint8
            np.testing.assert_array_equal(m.value, image)


def test_ground_truth_disparity_round_trips_exactly_with_its_nans(read_back):
    sample, got = read_back
    pairs = [
        *zip(got[contract.TRUTH_DISPARITY], sample.written[contract.TRUTH_DISPARITY], strict=True),
        *zip(got[contract.TRUTH_DEPTH], sample.written[contract.TRUTH_DEPTH], strict=True),
    ]
    for m, (_, disparity) in pairs:
        assert m.value.dtype == np.float32 and m.schema == contract.RAW_IMAGE
        np.testing.assert_array_equal(m.value, disparity)  # NaNs where they were


def test_calibration_round_trips_with_right_p_carrying_baseline(read_back):
    _, got = read_back
    for side in ("left", "right"):
        cal = got[contract.CALIBRATION_TOPICS[side]][0].value
        assert (cal.width, cal.height) == (RIG.width, RIG.height)
        np.testing.assert_array_equal(cal.K, RIG.intrinsics())
        np.testing.assert_array_equal(cal.P, RIG.projection(side))
    right = got[contract.RIGHT_CALIBRATION][0].value
    assert right.P[0, 3] == pytest.approx(-RIG.focal_px * RIG.baseline)


@pytest.mark.parametrize("topic", [contract.ODOM, contract.TRUTH_POSE])
def test_poses_round_trip(read_back, topic):
    sample, got = read_back
    for m, (t, pose) in zip(got[topic], sample.written[topic], strict=True):
        assert isinstance(m.value, OdomReading)
        assert m.value.stamp_ns == t
        assert (m.value.pose.x, m.value.pose.y) == (pose.x, pose.y)
        assert m.value.pose.theta == pytest.approx(math.remainder(pose.theta, math.tau), abs=1e-12)


def test_transforms_round_trip(read_back):
    sample, got = read_back
    for m, (_, transforms) in zip(got[contract.TF], sample.written[contract.TF], strict=True):
        assert len(m.value) == len(transforms)
        for a, b in zip(m.value, transforms, strict=True):
            assert (a.parent, a.child) == (b.parent, b.child)
            assert a.translation == pytest.approx(b.translation, abs=0)
            assert a.rotation == pytest.approx(b.rotation, abs=0)


def test_sonar_round_trips_with_no_echo_as_nan(read_back):
    sample, got = read_back
    for m, (_, reading) in zip(got[contract.SONAR], sample.written[contract.SONAR], strict=True):
        assert isinstance(m.value, SonarReading)
        assert m.value.stamp_ns == reading.stamp_ns
        np.testing.assert_array_equal(m.value.ranges, reading.ranges)
        np.testing.assert_array_equal(m.value.fired, reading.fired)
        np.testing.assert_array_equal(m.value.mounts, reading.mounts)
        assert (m.value.cone_angle, m.value.max_range) == (reading.cone_angle, reading.max_range)


def test_fly_cloud_overlay_grid_path_round_trip(read_back):
    sample, got = read_back
    for m, (_, (xyz, fit)) in zip(got[contract.FLIES], sample.written[contract.FLIES], strict=True):
        assert m.value.xyz.dtype == np.float32
        np.testing.assert_array_equal(m.value.xyz, xyz)
        np.testing.assert_array_equal(m.value.fitness, fit)
    overlays = zip(got[contract.FLIES_OVERLAY], sample.written[contract.FLIES_OVERLAY], strict=True)
    for m, (_, (uv, colours)) in overlays:
        np.testing.assert_array_equal(m.value.uv, uv)
        np.testing.assert_array_equal(m.value.colours, colours)
    grids = zip(
        got[contract.PLANNER_POTENTIAL], sample.written[contract.PLANNER_POTENTIAL], strict=True
    )
    for m, (_, (values, origin, cell)) in grids:
        np.testing.assert_array_equal(m.value.values, values)
        assert m.value.cell == cell
        assert (m.value.origin.x, m.value.origin.y) == (origin.x, origin.y)
        assert m.value.origin.theta == pytest.approx(origin.theta, abs=1e-12)
    maps = zip(got[contract.PLANNER_MAP], sample.written[contract.PLANNER_MAP], strict=True)
    for m, (_, (detected, inflated)) in maps:
        expected = np.where(detected, 100, np.where(inflated, 99, 0))
        assert m.value.values.dtype == np.uint8
        np.testing.assert_array_equal(m.value.values, expected)
    paths = zip(got[contract.PLANNER_PATH], sample.written[contract.PLANNER_PATH], strict=True)
    for m, (_, xyt) in paths:
        np.testing.assert_array_equal(m.value[:, :2], xyt[:, :2])
        np.testing.assert_allclose(m.value[:, 2], xyt[:, 2], atol=1e-12)


def test_command_and_scene_round_trip(read_back):
    sample, got = read_back
    cmds = zip(got[contract.PLANNER_COMMAND], sample.written[contract.PLANNER_COMMAND], strict=True)
    for m, (t, (linear, angular, status)) in cmds:
        assert m.value == {"stamp_ns": t, "linear": linear, "angular": angular, "status": status}
    shapes = got[contract.TRUTH_SCENE][0].value
    expected = sample.written[contract.TRUTH_SCENE][0][1]
    assert [type(s) for s in shapes] == [type(s) for s in expected]
    box, cyl = shapes
    box_in, cyl_in = expected
    assert box == box_in._replace(yaw=pytest.approx(box_in.yaw, abs=1e-12))
    assert cyl == cyl_in


def test_messages_come_in_log_time_order_keeping_write_order_on_ties(read_back):
    sample, _ = read_back
    msgs = list(open_log(sample.path).messages())
    times = [m.log_time_ns for m in msgs]
    assert times == sorted(times)
    # the conftest writes odometry ahead of the frame's images: the reader reorders them
    assert msgs[0].topic == contract.LEFT_CALIBRATION


def test_mono_image_and_non_contiguous_input(tmp_path):
    grey = np.arange(12 * 9, dtype=np.uint8).reshape(12, 9)
    rgb = np.arange(8 * 10 * 3, dtype=np.uint8).reshape(8, 10, 3)[:, ::-1]  # a strided view
    with LogWriter(tmp_path / "m.mcap") as log:
        log.write(contract.LEFT_IMAGE, 5, encode.raw_image(grey, 5, "camera_left"))
        log.write(contract.RIGHT_IMAGE, 5, encode.raw_image(rgb, 5, "camera_right"))
    left, right = (m.value for m in open_log(tmp_path / "m.mcap").messages())
    np.testing.assert_array_equal(left, grey)
    np.testing.assert_array_equal(right, rgb)
    assert not left.flags.writeable  # a view of the message bytes, not a copy


def test_encoders_reject_bad_shapes():
    with pytest.raises(ValueError, match="uint8"):
        encode.raw_image(np.zeros((4, 4, 3), dtype=np.float32), 0, "camera_left")
    with pytest.raises(ValueError, match=r"xyz \(N, 3\)"):
        encode.point_cloud(np.zeros((4, 2)), np.zeros(4), 0, "base_link")
    with pytest.raises(ValueError, match="negative"):
        encode.timestamp(-1)
    with pytest.raises(ValueError, match="'left' or 'right'"):
        encode.camera_calibration(RIG, "middle", 0)


def quat_matrix(q: tuple[float, float, float, float]) -> np.ndarray:
    x, y, z, w = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def test_static_transforms_place_cameras_and_sonars():
    tfs = {t.child: t for t in encode.static_transforms(RIG, SONAR)}
    assert set(tfs) == {"camera_left", "camera_right"} | {f"sonar_{i}" for i in range(6)}
    left = tfs["camera_left"]
    assert left.parent == "base_link" and left.rotation == OPTICAL_IN_BASE_QUAT
    assert left.translation == (RIG.mount_x, RIG.baseline / 2, RIG.mount_height)
    assert tfs["camera_right"].translation[1] == -RIG.baseline / 2
    np.testing.assert_allclose(quat_matrix(left.rotation), OPTICAL_TO_BASE, atol=1e-15)
    # the third sonar looks 10° to the right: its beam (x) points there in base_link
    s2 = tfs["sonar_2"]
    beam = quat_matrix(s2.rotation) @ [1.0, 0.0, 0.0]
    a = math.radians(-10.0)
    np.testing.assert_allclose(beam, [math.cos(a), math.sin(a), 0.0], atol=1e-15)
    assert s2.translation == pytest.approx((0.2 * math.cos(a), 0.2 * math.sin(a), 0.3))


def test_odom_transform_is_the_pose():
    t = encode.odom_transform(Pose2D(1.0, -2.0, math.pi / 2))
    assert (t.parent, t.child, t.translation) == ("odom", "base_link", (1.0, -2.0, 0.0))
    np.testing.assert_allclose(quat_matrix(t.rotation) @ [1, 0, 0], [0, 1, 0], atol=1e-15)
