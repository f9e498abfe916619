"""Bags whose tf tree is a real robot's (written with rosbags, a ZED-like chain): base_link
below base_footprint, odometry only as /tf odom → base_footprint, sonars and cameras hung
from other frames; and topic overrides that cannot be meant."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from rosbags.rosbag2 import Reader

from flylog.cli.main import cli
from flylog.errors import LogError
from flylog.ros2.bag import open_bag
from flylog.ros2.config import BagOptions
from flylog.ros2.export import export_ros2
from flylog.ros2.source import BagSource
from flylog.ros2.truth import bag_trajectories
from flylog.sensors import OdomReading
from tests.ros2 import bags
from tests.ros2.bags import BagSpec

LOG = Path(__file__).resolve().parents[2] / "fixtures" / "logs" / "turn.mcap"
HEIGHT = 0.12  # base_link above base_footprint
TF, TF_STATIC = "/tf", "/tf_static"
TF_TYPE = "tf2_msgs/msg/TFMessage"


def _statics(transforms, *, reverse: bool = False) -> list:
    """The tree of ``transforms`` (base_link → camera_*, sonar_*) rebuilt as a ZED driver
    and a base publish it: base_footprint → base_link (or base_link → base_footprint with
    ``reverse``), base_link → zed_camera_center → camera_* (the cameras' rotation on the
    last link), the sonars on base_footprint."""
    up = (0.0, 0.0, HEIGHT)
    out = [
        bags.transform(0, "base_link", "base_footprint", (0.0, 0.0, -HEIGHT), (0, 0, 0, 1))
        if reverse
        else bags.transform(0, "base_footprint", "base_link", up, (0, 0, 0, 1))
    ]
    for t in transforms:
        tr, q = t.transform.translation, t.transform.rotation
        quaternion = (q.x, q.y, q.z, q.w)
        if t.child_frame_id.startswith("sonar"):
            xyz = (tr.x, tr.y, tr.z + HEIGHT)
            out.append(bags.transform(0, "base_footprint", t.child_frame_id, xyz, quaternion))
        else:
            centre = f"zed_{t.child_frame_id}_centre"
            out.append(bags.transform(0, "base_link", centre, (tr.x, tr.y, tr.z), (0, 0, 0, 1)))
            out.append(bags.transform(0, centre, t.child_frame_id, (0, 0, 0), quaternion))
    return out


def _zed(items: list, *, reverse: bool = False) -> list:
    """``items`` with /tf_static rebuilt (:func:`_statics`) and the Odometry topic /odom
    replaced by /tf odom → base_footprint."""
    out = []
    for topic, msgtype, t_ns, msg in items:
        if topic == TF_STATIC:
            msg = bags.tf_message(_statics(msg.transforms, reverse=reverse))
        elif topic == "/odom":
            p, q = msg.pose.pose.position, msg.pose.pose.orientation
            xyz = (p.x, p.y, p.z - HEIGHT)
            tf = bags.transform(t_ns, "odom", "base_footprint", xyz, (q.x, q.y, q.z, q.w))
            topic, msgtype, msg = TF, TF_TYPE, bags.tf_message([tf])
        elif topic == TF:
            continue  # the exporter's odom → base_link: odometry is the one above
        out.append((topic, msgtype, t_ns, msg))
    return out


@pytest.mark.parametrize("reverse", [False, True], ids=["footprint above", "link above"])
def test_tf_odometry_and_sonars_through_the_whole_tree(tmp_path, reverse):
    spec = BagSpec(frames=3, sonars=(-0.5, 0.0, 0.5))
    plain = BagSource(bags.make_bag(tmp_path / "plain", spec), BagOptions())
    items = bags.messages(spec)
    zed = BagSource(bags.write_bag(tmp_path / "zed", _zed(items, reverse=reverse)), BagOptions())
    assert zed.roles.odom_from_tf
    assert np.allclose(zed.sonar_mounts, plain.sonar_mounts, atol=1e-12)
    assert (zed.rig.mount_x, zed.rig.mount_height) == pytest.approx(
        (plain.rig.mount_x, plain.rig.mount_height), abs=1e-12
    )
    odom = [m.value.pose for m in zed.records() if isinstance(m.value, OdomReading)]
    want = [m.value.pose for m in plain.records() if isinstance(m.value, OdomReading)]
    assert len(odom) == len(want) == 3
    for got, expected in zip(odom, want, strict=True):
        assert (got.x, got.y, got.theta) == pytest.approx((expected.x, expected.y, expected.theta))
    assert zed.start == pytest.approx(plain.start)


def test_a_sonar_the_tree_does_not_connect_is_refused(tmp_path):
    items = bags.messages(BagSpec(frames=1))
    for _, _, _, msg in items[:1]:  # /tf_static: sonar_0 hung from a frame of its own
        msg.transforms[-1].header.frame_id = "elsewhere"
    assert items[0][0] == TF_STATIC
    with pytest.raises(LogError, match="does not connect base_link and its frame 'sonar_0'"):
        BagSource(bags.write_bag(tmp_path / "bag", items), BagOptions())


def _rewritten(bag: Path, out: Path) -> Path:
    """An exported bag's messages as another tool would record them: /tf_static and the
    odometry of :func:`_zed`, written by rosbags."""
    items = []
    with Reader(bag) as reader:
        for connection, t_ns, raw in reader.messages():
            msg = bags.STORE.deserialize_cdr(raw, connection.msgtype)
            items.append((connection.topic, connection.msgtype, t_ns, msg))
    return bags.write_bag(out, _zed(items), custom=open_bag(bag).custom)


@pytest.fixture(scope="module")
def zed_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("zed")
    export_ros2(LOG, root / "exported", truth=True)
    return _rewritten(root / "exported", root / "zed")


def test_replay_and_metrics_of_a_bag_with_tf_odometry_only(zed_bag, tmp_path):
    odom = bag_trajectories(zed_bag)["odom"]
    assert len(odom) > 1 and math.isfinite(float(np.sum(odom.xy)))
    run = tmp_path / "run.mcap"
    replayed = CliRunner().invoke(
        cli,
        ["replay", str(zed_bag), "-o", str(run), "--flies", "100", "--generations-per-frame", "1"],
    )
    assert replayed.exit_code == 0, replayed.output
    assert "standing at the origin" not in replayed.stderr
    scored = CliRunner().invoke(
        cli, ["metrics", str(run), "--log", str(zed_bag), "-o", str(tmp_path / "m.parquet")]
    )
    assert scored.exit_code == 0, scored.output


@pytest.mark.parametrize(
    ("overrides", "words"),
    [
        (["left=/stereo/right/image_rect"], "left and right: both are /stereo/right/image_rect"),
        (["left=/stereo/left/image_rect", "left=/stereo/left/image_rect"], "left is given twice"),
        (["right=/stereo/left/image_rect"], "both are /stereo/left/image_rect"),
    ],
)
def test_overrides_that_cannot_be_meant_are_refused(tmp_path, overrides, words):
    bag = bags.make_bag(tmp_path / "bag", BagSpec(frames=1))
    args = ["replay", str(bag), "-o", str(tmp_path / "run.mcap")]
    for item in overrides:
        args += ["--topic", item]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 2, result.output
    assert words in result.stderr and "--topic" in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag"]


def test_a_metadata_file_that_is_not_utf8_is_exit_2(tmp_path):
    bag = bags.make_bag(tmp_path / "bag", BagSpec(frames=1))
    meta = bag / "metadata.yaml"
    meta.write_bytes(meta.read_bytes().replace(b"rosbag2_bagfile_information", b"\xff\xfe", 1))
    result = CliRunner().invoke(cli, ["replay", str(bag), "-o", str(tmp_path / "run.mcap")])
    assert result.exit_code == 2, result.output
    assert "metadata.yaml: the bag's metadata is not UTF-8 text" in result.stderr
