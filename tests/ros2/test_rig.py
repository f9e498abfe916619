"""The rig of a real camera pair from a bag that rosbags wrote: the principal point and
doffs of the CameraInfo P matrices, the mount's position and rotation from /tf_static, and
what flylog's stereo rig cannot represent refused by name."""

import math

import cv2
import numpy as np
import pytest

from flylog.errors import LogError
from flylog.geometry import StereoRig
from flylog.ros2.config import BagOptions
from flylog.ros2.source import BagSource
from tests.ros2 import bags
from tests.ros2.bags import BagSpec, make_bag

PAN, TILT, ROLL = 4.0, 17.5, -2.5  # degrees
PRINCIPAL = (35.25, 21.75)  # px, off the centre (31.5, 23.5)
DOFFS = 3.5  # px


def rotation(pan=PAN, tilt=TILT, roll=ROLL):
    """Rz(pan)·Ry(tilt)·Rx(roll)·(level optical axes), from OpenCV's Rodrigues."""

    def about(axis, deg):
        v = np.zeros(3)
        v[axis] = math.radians(deg)
        return cv2.Rodrigues(v)[0]

    level = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    return about(2, pan) @ about(1, tilt) @ about(0, roll) @ level


def tilted_spec(**kw):
    q = bags.turned_q(math.radians(PAN), math.radians(TILT), math.radians(ROLL))
    return BagSpec(frames=2, camera_q=q, principal_point=PRINCIPAL, doffs=DOFFS, **kw)


def right_of_left(axes=None):
    axes = rotation() if axes is None else axes
    return tuple(float(v) for v in np.array(bags.MOUNT) + bags.BASELINE * axes[:, 0])


def rig_of(path):
    return BagSource(path, BagOptions()).rig


def assert_rig(got, axes):
    left = np.array(bags.MOUNT)
    mid = left + bags.BASELINE / 2 * axes[:, 0]
    want = StereoRig(
        width=bags.W,
        height=bags.H,
        focal_px=bags.FOCAL,
        baseline=bags.BASELINE,
        principal_point=PRINCIPAL,
        doffs=DOFFS,
        frame_rate=10.0,
        mount_x=got.mount_x,
        mount_y=got.mount_y,
        mount_height=got.mount_height,
        pan=got.pan,
        tilt=got.tilt,
        roll=got.roll,
    )
    assert got == want  # size, focal length, baseline, principal point, doffs: exactly
    assert (got.pan, got.tilt, got.roll) == pytest.approx((PAN, TILT, ROLL), abs=1e-12)
    assert (got.mount_x, got.mount_y, got.mount_height) == pytest.approx(tuple(mid), abs=1e-15)
    assert got.camera_position("left") == pytest.approx(bags.MOUNT, abs=1e-15)
    np.testing.assert_allclose(got.rotation(), axes, rtol=0, atol=1e-15)


def test_a_tilted_off_centre_bag_gives_its_rig(tmp_path):
    assert_rig(rig_of(make_bag(tmp_path / "bag", tilted_spec())), rotation())


def test_the_right_cameras_transform_checks_the_baseline_and_changes_nothing(tmp_path):
    got = rig_of(make_bag(tmp_path / "bag", tilted_spec(right_mount=right_of_left())))
    assert_rig(got, rotation())
    alone = rig_of(make_bag(tmp_path / "alone", tilted_spec()))  # placed by the right P
    assert_rig(alone, rotation())
    for side in ("left", "right"):
        assert got.camera_position(side) == pytest.approx(alone.camera_position(side), abs=1e-15)


def test_a_right_camera_info_in_the_left_frame_is_placed_by_its_p(tmp_path):
    # some drivers stamp both CameraInfos with the left optical frame: P alone places the
    # right camera, even when /tf_static has a (here wrong) camera_right
    def same_frame(side, msg):
        msg.header.frame_id = "camera_left"

    spec = tilted_spec(right_mount=(0.0, 0.0, 0.0))
    assert_rig(
        rig_of(bags.write_bag(tmp_path / "bag", _with_camera_info(spec, same_frame))), rotation()
    )


def test_a_raw_pair_takes_the_orientation_of_its_rectified_frames(tmp_path):
    # the raw cameras pitch 5° more than their rectified frames: R (raw → rectified
    # coordinates) turns them back about the optical x axis
    r = cv2.Rodrigues(np.array([math.radians(-5.0), 0.0, 0.0]))[0]
    raw_axes = rotation() @ r  # rectified axes = raw axes · Rᵀ
    spec = tilted_spec(right_mount=right_of_left())
    spec.camera_q = _quaternion(raw_axes)
    items = []
    for topic, mtype, t, msg in bags.messages(spec):
        if mtype == "sensor_msgs/msg/CameraInfo":
            msg.r = r.ravel().copy()
        items.append((topic, mtype, t, msg))
    assert_rig(rig_of(bags.write_bag(tmp_path / "bag", items)), rotation())


def _quaternion(m):
    """x, y, z, w of a rotation matrix (w well away from 0)."""
    w = math.sqrt(1.0 + m[0, 0] + m[1, 1] + m[2, 2]) / 2
    return (
        (m[2, 1] - m[1, 2]) / (4 * w),
        (m[0, 2] - m[2, 0]) / (4 * w),
        (m[1, 0] - m[0, 1]) / (4 * w),
        w,
    )


def _with_camera_info(spec, change):
    items = []
    for topic, mtype, t, msg in bags.messages(spec):
        if mtype == "sensor_msgs/msg/CameraInfo":
            change("left" if "left" in topic else "right", msg)
        items.append((topic, mtype, t, msg))
    return items


def _refused(tmp_path, items, pattern, name="bag"):
    with pytest.raises(LogError, match=pattern) as caught:
        rig_of(bags.write_bag(tmp_path / name, items))
    assert str(tmp_path / name) in str(caught.value)


def test_non_square_pixels_are_refused(tmp_path):
    def change(side, msg):
        msg.p[5] = bags.FOCAL * 1.01

    _refused(
        tmp_path,
        _with_camera_info(tilted_spec(), change),
        r"camera_info and /stereo/right/camera_info: the left P has fx = 40.0, fy = 40.4 and "
        r"skew 0.0: flylog's stereo rig needs square pixels",
    )


def test_an_unaligned_right_camera_is_refused(tmp_path):
    def rows(side, msg):
        if side == "right":
            msg.p[6] += 0.5

    _refused(
        tmp_path,
        _with_camera_info(tilted_spec(), rows),
        r"the right P has cy = 22.25, the left 21.75: the rows of a rectified pair align",
    )

    def below(side, msg):
        if side == "right":
            msg.p[7] = -bags.FOCAL * 0.01  # fy·Ty, Ty = −0.01: 1 cm below the left camera

    _refused(
        tmp_path,
        _with_camera_info(tilted_spec(), below),
        r"the right P puts the right camera 0.01 m down and 0.0 m forward of the left one",
        name="below",
    )


def test_a_right_transform_off_the_left_cameras_x_axis_is_refused(tmp_path):
    x, y, z = right_of_left()
    spec = tilted_spec(right_mount=(x, y, z - 0.02))
    _refused(
        tmp_path,
        bags.messages(spec),
        r"/tf_static puts the cameras at .* m, but .* give a baseline of 0.1 m: flylog's "
        r"stereo rig needs the right camera 0.1 m along the left camera's x axis",
    )


def test_cameras_turned_differently_are_refused(tmp_path):
    spec = tilted_spec(right_mount=right_of_left())
    items = []
    for topic, mtype, t, msg in bags.messages(spec):
        if topic == "/tf_static":
            right = msg.transforms[1].transform.rotation
            right.x, right.y, right.z, right.w = bags.turned_q(0.0, math.radians(TILT + 1))
        items.append((topic, mtype, t, msg))
    _refused(tmp_path, items, r"/tf_static turns the two cameras differently")


def test_a_mount_beyond_the_rigs_range_is_refused(tmp_path):
    spec = BagSpec(frames=2, camera_q=bags.turned_q(tilt=math.radians(70.0)))
    _refused(
        tmp_path,
        bags.messages(spec),
        r"/tf_static mounts the cameras with a tilt of 70°: flylog's stereo rig represents "
        r"-60° to 60°",
    )


def _right_p(index, value):
    def change(side, msg):
        if side == "right":
            msg.p[index] = value

    return change


def _right_size(side, msg):
    if side == "right":
        msg.width, msg.height = bags.W * 2, bags.H * 2


@pytest.mark.parametrize(
    ("change", "pattern"),
    [
        (
            _right_p(0, 41.0),
            r"the right P has fx = 41.0 and fy = 40.0, the left 40.0: .* one focal",
        ),
        (_right_p(3, 4.0), r"baseline of -0.1 m \(−P\[0, 3\] / fx\): the right camera of a stereo"),
        (_right_p(1, 0.5), r"the right P has skew 0.5: flylog's stereo rig needs square pixels"),
        (_right_size, r"camera_info: the cameras differ in size \(64×48 and 128×96\)"),
    ],
    ids=["focal", "baseline", "skew", "size"],
)
def test_what_the_rig_cannot_represent_is_refused_by_name(tmp_path, change, pattern):
    _refused(tmp_path, _with_camera_info(tilted_spec(), change), pattern)
