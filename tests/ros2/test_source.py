"""Reading bags that rosbags wrote (not flylog's exporter): encodings, rectification,
pairing, sonar cycles, odometry, topic discovery, single files and split bags."""

import math
import warnings

import numpy as np
import pytest

from flylog.errors import LogError
from flylog.io.pairing import UnpairedImagesWarning
from flylog.ros2.config import BagOptions
from flylog.ros2.odometry import NoOdometryWarning, TiltedOdometryWarning
from flylog.ros2.source import BagSource
from flylog.sensors import OdomReading, SonarReading, StereoPair
from tests.ros2 import bags
from tests.ros2.bags import BagSpec, make_bag


def records(path, **options):
    source = BagSource(path, BagOptions(**options))
    return source, [m.value for m in source.records()]


def pairs(values):
    return [v for v in values if isinstance(v, StereoPair)]


def test_rig_start_and_records_of_a_rosbags_bag(tmp_path):
    source, values = records(make_bag(tmp_path / "bag"))
    rig = source.rig
    assert (rig.width, rig.height, rig.focal_px) == (bags.W, bags.H, bags.FOCAL)
    assert rig.baseline == pytest.approx(bags.BASELINE)
    assert (rig.mount_x, rig.mount_height) == (bags.MOUNT[0], bags.MOUNT[2])
    assert rig.frame_rate == pytest.approx(10.0)
    assert source.goal is None
    left, right = bags.stereo_views()
    got = pairs(values)
    assert [p.stamp_ns for p in got] == [k * bags.PERIOD_NS for k in range(4)]
    assert np.array_equal(got[0].left, left) and np.array_equal(got[0].right, right)
    odom = [v for v in values if isinstance(v, OdomReading)]
    assert [o.pose.x for o in odom] == pytest.approx([0.0, 0.01, 0.02, 0.03])


ENCODINGS = {
    "rgb8": lambda rgb: rgb,
    "bgr8": lambda rgb: rgb[..., ::-1],
    "rgba8": lambda rgb: np.dstack([rgb, np.full(rgb.shape[:2], 255, np.uint8)]),
    "bgra8": lambda rgb: np.dstack([rgb[..., ::-1], np.zeros(rgb.shape[:2], np.uint8)]),
}


@pytest.mark.parametrize("encoding", sorted(ENCODINGS))
def test_colour_encodings_read_back_exactly(tmp_path, encoding):
    spec = BagSpec(frames=1, encoding=encoding, image_of=lambda side, rgb: ENCODINGS[encoding](rgb))
    _, values = records(make_bag(tmp_path / "bag", spec))
    assert np.array_equal(pairs(values)[0].left, bags.stereo_views()[0])


def test_mono8_and_mono16_are_grey_and_mono16_keeps_its_top_byte(tmp_path):
    grey = bags.stereo_views()[0][..., 1]
    spec = BagSpec(frames=1, encoding="mono8", image_of=lambda side, rgb: rgb[..., 1])
    _, values = records(make_bag(tmp_path / "m8", spec))
    assert np.array_equal(pairs(values)[0].left, grey)
    wide = BagSpec(
        frames=1,
        encoding="mono16",
        image_of=lambda side, rgb: rgb[..., 1].astype(np.uint16) * 256 + 77,
    )
    _, values = records(make_bag(tmp_path / "m16", wide))
    assert np.array_equal(pairs(values)[0].left, grey)


def mosaic_rggb(rgb):
    out = np.empty(rgb.shape[:2], np.uint8)
    out[0::2, 0::2] = rgb[0::2, 0::2, 0]
    out[0::2, 1::2] = rgb[0::2, 1::2, 1]
    out[1::2, 0::2] = rgb[1::2, 0::2, 1]
    out[1::2, 1::2] = rgb[1::2, 1::2, 2]
    return out


def test_bayer_rggb8_is_demosaiced_to_the_right_colours(tmp_path):
    spec = BagSpec(frames=1, encoding="bayer_rggb8", image_of=lambda side, rgb: mosaic_rggb(rgb))
    _, values = records(make_bag(tmp_path / "bag", spec))
    got = pairs(values)[0].left.astype(float)
    want = bags.stereo_views()[0].astype(float)
    inner = (slice(2, -2), slice(2, -2))
    # a smooth texture demosaics within a few grey levels; a swapped pattern is ~40 off
    assert np.abs(got[inner] - want[inner]).mean() < 6.0


@pytest.mark.parametrize(("fmt", "tolerance"), [("png", 0.0), ("jpeg", 10.0)])
def test_compressed_images(tmp_path, fmt, tolerance):
    _, values = records(make_bag(tmp_path / "bag", BagSpec(frames=1, encoding=fmt)))
    got = pairs(values)[0].left.astype(float)
    want = bags.stereo_views()[0]
    # jpeg at OpenCV's default quality: 8 grey levels on this saturated texture; red and
    # blue swapped would be 60
    assert np.abs(got - want).mean() <= tolerance < np.abs(got - want[..., ::-1]).mean()


def test_an_unknown_encoding_names_the_topic_and_the_encoding(tmp_path):
    spec = BagSpec(frames=1, encoding="yuv422", image_of=lambda side, rgb: rgb[..., :2])
    with pytest.raises(LogError, match=r"/stereo/left/image_rect: image encoding 'yuv422'"):
        records(make_bag(tmp_path / "bag", spec))


def distorted(rectified, model, d, shift_cx=0.0):
    """A raw image whose rectification (K, D, R = I, P) is ``rectified``: each raw pixel
    takes the rectified pixel its undistorted ray lands on."""
    import cv2

    k = bags.k_matrix(cx=(bags.W - 1) / 2 + shift_cx).reshape(3, 3)
    p = bags.p_matrix()[:12].reshape(3, 4)[:, :3]
    u, v = np.meshgrid(np.arange(bags.W, dtype=np.float64), np.arange(bags.H, dtype=np.float64))
    pts = np.stack([u.ravel(), v.ravel()], axis=1).reshape(-1, 1, 2)
    if model == "equidistant":
        und = cv2.fisheye.undistortPoints(pts, k, np.asarray(d[:4]), P=p)
    else:
        und = cv2.undistortPoints(pts, k, np.asarray(d), P=p)
    mx = und[:, 0, 0].reshape(bags.H, bags.W).astype(np.float32)
    my = und[:, 0, 1].reshape(bags.H, bags.W).astype(np.float32)
    return cv2.remap(rectified, mx, my, cv2.INTER_LINEAR), k.ravel()


@pytest.mark.parametrize(
    ("model", "d"),
    [("plumb_bob", [-0.12, 0.03, 0.0005, -0.0004, 0.0]), ("equidistant", [0.05, -0.01, 0.0, 0.0])],
)
def test_raw_images_are_rectified_onto_p(tmp_path, model, d):
    left, right = bags.stereo_views()
    items = []
    for topic, mtype, t, msg in bags.messages(BagSpec(frames=1)):
        if mtype == "sensor_msgs/msg/CameraInfo":
            msg.distortion_model, msg.d = model, np.asarray(d, dtype=np.float64)
            msg.k = distorted(left, model, d, shift_cx=1.5)[1]
        elif mtype == "sensor_msgs/msg/Image":
            rect = left if "left" in topic else right
            raw = distorted(rect, model, d, shift_cx=1.5)[0]
            msg = bags.image(t, msg.header.frame_id, raw)
        items.append((topic, mtype, t, msg))
    source, values = records(bags.write_bag(tmp_path / "bag", items))
    got = pairs(values)[0]
    inner = (slice(6, -6), slice(6, -6))
    raw_err = np.abs(distorted(left, model, d, 1.5)[0][inner].astype(float) - left[inner]).mean()
    err = np.abs(got.left[inner].astype(float) - left[inner]).mean()
    # two bilinear resamplings (the test's distortion, the rectification): 3.5 grey levels
    # (plumb_bob); the raw image is 31 off
    assert err < 5.0 < 20.0 < raw_err
    assert source.rig.focal_px == bags.FOCAL  # the rig is the rectified P's


def test_unsynchronised_cameras_pair_by_nearest_stamp_and_count_the_unpaired(tmp_path):
    spec = BagSpec(frames=4, right_delay_ns=30_000_000)
    items = bags.messages(spec)
    left, _ = bags.stereo_views()
    t = 4 * bags.PERIOD_NS
    items.append((spec.left, "sensor_msgs/msg/Image", t, bags.image(t, "camera_left", left)))
    with pytest.warns(UnpairedImagesWarning, match="1 images"):
        source, values = records(bags.write_bag(tmp_path / "bag", items))
    assert [p.stamp_ns for p in pairs(values)] == [k * bags.PERIOD_NS for k in range(4)]
    assert source.unpaired == 1
    with pytest.warns(UnpairedImagesWarning, match="9 images"):  # 0.2 periods < 30 ms
        source, values = records(bags.write_bag(tmp_path / "b2", items), pair_tolerance=0.2)
    assert pairs(values) == []


def test_sonar_cycles_mounts_and_rep117_no_echo(tmp_path):
    yaws = (-0.5, 0.0, 0.5)
    spec = BagSpec(frames=1, sonars=yaws)
    items = [m for m in bags.messages(spec) if not m[0].startswith("/sonar_")]
    t1 = 40_000_000  # a second cycle: one reading 40 ms after the first
    for i, value in enumerate([math.inf, math.nan, 3.5]):
        items.append(
            (f"/sonar_{i}", "sensor_msgs/msg/Range", 0, bags.range_msg(0, f"sonar_{i}", value))
        )
    items.append(("/sonar_0", "sensor_msgs/msg/Range", t1, bags.range_msg(t1, "sonar_0", 0.01)))
    items.append(
        (
            "/sonar_1",
            "sensor_msgs/msg/Range",
            t1 + 10_000_000,
            bags.range_msg(t1 + 10_000_000, "sonar_1", 1.25),
        )
    )
    items.sort(key=lambda m: m[2])
    _, values = records(bags.write_bag(tmp_path / "bag", items), sonar_window=0.03)
    cycles = [v for v in values if isinstance(v, SonarReading)]
    assert [c.stamp_ns for c in cycles] == [0, t1]
    assert np.isnan(cycles[0].ranges).all()  # +inf, NaN, beyond max_range: no echo
    assert np.isnan(cycles[1].ranges[0])  # below min_range
    assert cycles[1].ranges[1] == pytest.approx(1.25)
    assert cycles[0].mounts[:, 2] == pytest.approx(yaws)
    assert cycles[0].mounts[2, :2] == pytest.approx([0.2 * math.cos(0.5), 0.2 * math.sin(0.5)])
    assert cycles[0].cone_angle == pytest.approx(math.radians(15))


def test_tilted_odometry_is_projected_with_one_warning(tmp_path):
    items = [m for m in bags.messages(BagSpec(frames=3)) if m[0] != "/odom"]
    for k in range(3):
        t = k * bags.PERIOD_NS
        items.append(("/odom", "nav_msgs/msg/Odometry", t, bags.odometry(t, 1.0, 2.0, 0.3, 0.2)))
    items.sort(key=lambda m: m[2])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        _source, values = records(bags.write_bag(tmp_path / "bag", items))
    tilted = [w for w in caught if issubclass(w.category, TiltedOdometryWarning)]
    assert len(tilted) == 1
    odom = [v for v in values if isinstance(v, OdomReading)]
    assert odom[0].pose.theta == pytest.approx(0.3) and odom[0].pose.x == 1.0


def test_tf_odometry_when_there_is_no_odometry_topic(tmp_path):
    items = [m for m in bags.messages(BagSpec(frames=2, odom=False))]
    for k in range(2):
        t = k * bags.PERIOD_NS
        tf = bags.tf_message(
            [bags.transform(t, "odom", "base_link", (0.5 * k, 0, 0), bags.yaw_q(0.1))]
        )
        items.append(("/tf", "tf2_msgs/msg/TFMessage", t, tf))
    items.sort(key=lambda m: m[2])
    source, values = records(bags.write_bag(tmp_path / "bag", items))
    assert source.roles.odom_from_tf
    odom = [v for v in values if isinstance(v, OdomReading)]
    assert [o.pose.x for o in odom] == [0.0, 0.5]
    assert odom[1].pose.theta == pytest.approx(0.1)


def test_no_odometry_warns_and_starts_at_the_origin(tmp_path):
    with pytest.warns(NoOdometryWarning, match="without proprioception"):
        source, values = records(make_bag(tmp_path / "bag", BagSpec(odom=False)))
    assert source.start is None
    assert not [v for v in values if isinstance(v, OdomReading)]


def test_ambiguous_and_missing_roles_list_the_candidates(tmp_path):
    spec = BagSpec(frames=1)
    items = bags.messages(spec)
    left, _ = bags.stereo_views()
    extra = "/stereo/left/image_mono"
    items.append((extra, "sensor_msgs/msg/Image", 0, bags.image(0, "camera_left", left)))
    items.append(("/odom2", "nav_msgs/msg/Odometry", 0, bags.odometry(0, 0, 0, 0)))
    path = bags.write_bag(tmp_path / "bag", items)
    with pytest.raises(LogError) as err:
        BagSource(path, BagOptions())
    text = str(err.value)
    assert "left: several image topics" in text and f"{extra} (sensor_msgs/msg/Image)" in text
    assert "odom: several Odometry topics" in text and "/odom2 (nav_msgs/msg/Odometry)" in text
    assert "right:" not in text
    source = BagSource(path, BagOptions(topics=(f"left={extra}", "odom=/odom2")))
    assert (source.roles.left, source.roles.odom) == (extra, "/odom2")


def test_truth_topics_are_never_candidates(tmp_path):
    items = bags.messages(BagSpec(frames=1, odom=False))
    items.append(("/truth/odom", "nav_msgs/msg/Odometry", 0, bags.odometry(0, 5, 5, 0)))
    with pytest.warns(NoOdometryWarning):
        source = BagSource(bags.write_bag(tmp_path / "bag", items), BagOptions())
    assert source.roles.odom is None


def test_a_single_mcap_file_and_a_bag_split_in_two_files(tmp_path):
    one = make_bag(tmp_path / "bag")
    _, whole = records(one / "bag.mcap")
    assert len(pairs(whole)) == 4
    items = bags.messages(BagSpec())
    half = [m for m in items if m[2] < 2 * bags.PERIOD_NS]
    rest = [m for m in items if m[2] >= 2 * bags.PERIOD_NS]
    bags.write_bag(tmp_path / "a", half)
    bags.write_bag(tmp_path / "b", [m for m in rest if m[0] != "/tf_static"])
    split = tmp_path / "split"
    split.mkdir()
    (tmp_path / "a" / "a.mcap").rename(split / "a.mcap")
    (tmp_path / "b" / "b.mcap").rename(split / "b.mcap")
    meta = (tmp_path / "a" / "metadata.yaml").read_text()
    meta = meta.replace(
        "relative_file_paths:\n  - a.mcap", "relative_file_paths:\n  - a.mcap\n  - b.mcap"
    )
    (split / "metadata.yaml").write_text(meta)
    _, values = records(split)
    assert [p.stamp_ns for p in pairs(values)] == [p.stamp_ns for p in pairs(whole)]
