"""Bags replay cannot use: exit 2 naming the bag, the topic and the problem, nothing
written; a truncated bag is read up to the damage with a warning; a bag without a goal
replays with the planner off."""

import math
import os

import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner
from mcap.writer import Writer as McapWriter

from flylog.cli.main import cli
from flylog.errors import LogError
from flylog.io.reader import open_log
from flylog.ros2.bag import open_bag
from flylog.ros2.export import export_ros2
from tests.replay.test_replay import CORRIDOR
from tests.ros2 import bags
from tests.ros2.bags import BagSpec, make_bag, write_bag

FAST = ["--flies", "64", "--generations-per-frame", "1"]


def replay_cli(source, out, *extra):
    return CliRunner().invoke(cli, ["replay", str(source), "-o", str(out), *FAST, *extra])


def refused(tmp_path, bag, *needles, extra=()):
    out = tmp_path / "run.mcap"
    result = replay_cli(bag, out, *extra)
    assert result.exit_code == 2, result.output
    text = " ".join(result.output.split())
    for needle in (str(bag), *needles):
        assert needle in text, (needle, text)
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith("run")) == []
    return text


def test_a_bag_without_the_needed_types_lists_every_role(tmp_path):
    items = [m for m in bags.messages(BagSpec(frames=2)) if m[0] == "/odom"]
    text = refused(tmp_path, write_bag(tmp_path / "bag", items), "cannot tell which topics")
    assert "left: no image topic" in text and "right: no image topic" in text


def test_damaged_cdr_names_the_topic(tmp_path):
    def cut(topic, data):
        return data[:40] if topic.endswith("left/camera_info") else data

    bag = write_bag(tmp_path / "bag", bags.messages(BagSpec()), serialize=cut)
    refused(tmp_path, bag, "/stereo/left/camera_info", "is damaged")


def test_a_damaged_image_mid_bag_leaves_nothing_behind(tmp_path):
    count = {"n": 0}

    def cut(topic, data):
        if topic.endswith("right/image_rect"):
            count["n"] += 1
            if count["n"] == 3:
                return data[:100]
        return data

    bag = write_bag(tmp_path / "bag", bags.messages(BagSpec()), serialize=cut)
    refused(tmp_path, bag, "/stereo/right/image_rect", "at 200000000 ns is damaged")


def test_camera_info_of_another_size_than_the_images(tmp_path):
    items = []
    for topic, mtype, t, msg in bags.messages(BagSpec(frames=2)):
        if mtype == "sensor_msgs/msg/CameraInfo":
            msg = bags.camera_info(
                t, msg.header.frame_id, msg.p[3], size=(80, 60),
                k=bags.k_matrix(39.5, 29.5), p=bags.p_matrix(msg.p[3], 39.5, 29.5),
            )  # fmt: skip
        items.append((topic, mtype, t, msg))
    refused(
        tmp_path, write_bag(tmp_path / "bag", items),
        "/stereo/left/image_rect has 64×48 images but /stereo/left/camera_info calibrates 80×60",
    )  # fmt: skip


def test_a_range_topic_without_a_transform(tmp_path):
    items = bags.messages(BagSpec(frames=2))
    items.append(("/sonar_9", "sensor_msgs/msg/Range", 0, bags.range_msg(0, "sonar_9", 1.0)))
    refused(tmp_path, write_bag(tmp_path / "bag", items), "topic /sonar_9", "frame 'sonar_9'")


def test_a_directory_without_metadata_yaml(tmp_path):
    bag = make_bag(tmp_path / "bag")
    (bag / "metadata.yaml").unlink()
    refused(tmp_path, bag, "without metadata.yaml", "bag.mcap")


def test_a_ros1_bag_and_non_square_pixels(tmp_path):
    ros1 = tmp_path / "old.bag"
    ros1.write_bytes(b"#ROSBAG V2.0\n" + bytes(64))
    refused(tmp_path, ros1, "is a ROS 1 bag")
    items = []
    for topic, mtype, t, msg in bags.messages(BagSpec(frames=2)):
        if mtype == "sensor_msgs/msg/CameraInfo":
            msg.p[5] = 41.0  # fy ≠ fx = 40
        items.append((topic, mtype, t, msg))
    refused(
        tmp_path, write_bag(tmp_path / "rect", items),
        "/stereo/left/camera_info and /stereo/right/camera_info: the left P has fx = 40.0, "
        "fy = 41.0", "needs square pixels",
    )  # fmt: skip


def test_ros2idl_schemas_are_refused_by_name(tmp_path):
    path = tmp_path / "idl.mcap"
    with path.open("wb") as fh:
        writer = McapWriter(fh)
        writer.start(profile="ros2", library="test")
        schema = writer.register_schema("sensor_msgs/msg/Range", "ros2idl", b"module x {};")
        channel = writer.register_channel("/r", "cdr", schema)
        writer.add_message(channel, 0, b"\x00\x01\x00\x00", 0)
        writer.finish()
    with pytest.raises(LogError, match=r"topic /r has a 'ros2idl' schema") as refusal:
        list(open_bag(path).messages())
    assert str(refusal.value).startswith(f"{path}: ")


def test_a_truncated_bag_is_read_up_to_the_damage_with_a_warning(tmp_path):
    bag = export_ros2(CORRIDOR, tmp_path / "bag").output  # 3.5 MB: several chunks
    mcap = bag / "bag.mcap"
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(mcap.read_bytes()[: os.path.getsize(mcap) * 2 // 3])
    out = tmp_path / "run.mcap"
    result = replay_cli(cut, out)
    assert result.exit_code == 0, result.output
    assert "truncated or unfinished" in result.output
    frames = int(result.output.split(" frames")[0].rsplit(" ", 1)[1])
    assert 10 < frames < 31  # corridor has 31


def test_without_a_goal_the_planner_is_off_and_said_to_be(tmp_path):
    bag = make_bag(tmp_path / "bag", BagSpec(frames=6))
    out = tmp_path / "run.mcap"
    result = replay_cli(bag, out)
    assert result.exit_code == 0, result.output
    assert "gives no goal" in result.output and "planner off" in result.output
    topics = open_log(out).topics()
    assert "/flies" in topics and not [t for t in topics if t.startswith("/planner/")]
    table = pq.read_table(out.with_suffix(".parquet"))
    assert table.num_rows == 0  # one row per planner tick, and the planner never ticks
    with_goal = tmp_path / "goal.mcap"
    result = replay_cli(bag, with_goal, "--goal", "3,0")
    assert result.exit_code == 0, result.output
    assert "/planner/command" in open_log(with_goal).topics()
    assert math.isfinite(pq.read_table(with_goal.with_suffix(".parquet"))["linear_m_s"][0].as_py())


def test_export_refuses_an_existing_output_and_leaves_nothing_on_failure(tmp_path):
    log = tmp_path / "not-a-log.mcap"
    log.write_bytes(b"nope")
    result = CliRunner().invoke(cli, ["export", str(log), "--ros2", str(tmp_path / "out")])
    assert result.exit_code == 2 and "not an MCAP file" in result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["not-a-log.mcap"]
    (tmp_path / "out").mkdir()
    result = CliRunner().invoke(cli, ["export", str(log), "--ros2", str(tmp_path / "out")])
    assert result.exit_code == 2 and "exists" in result.output


def test_metrics_against_a_bag_without_ground_truth_says_what_is_missing(tmp_path):
    from flylog.ros2.truth import bag_truth

    with pytest.raises(LogError, match=r"lacks /truth/odom \(the true pose\), custom_data "):
        bag_truth(make_bag(tmp_path / "bag"))
