"""`flylog export RUN --ros2 OUT`: a run as standard ROS 2 messages, read back with rosbags
and with mcap-ros2-support's decoder (an independent reader), against the run itself; and
`flylog export RUN --ply DIR`, read back with plyfile."""

import numpy as np
import pytest
from click.testing import CliRunner
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from plyfile import PlyData
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from flylog.cli.main import cli
from flylog.errors import LogError
from flylog.fly.confidence import ConfidenceModel
from flylog.fly.depth_image import sparse_depth
from flylog.fly.snapshot_export import export_ply, snapshot_name
from flylog.io import contract
from flylog.io.reader import open_log
from flylog.metrics.config import MetricsConfig
from flylog.metrics.score import run_facts
from flylog.replay.inputs import log_rig
from flylog.replay.run import replay
from flylog.ros2 import run_export as rx
from flylog.ros2.export import export_ros2
from tests.replay.test_replay import CORRIDOR, SMALL

# A model whose confidence is the fitness's rank: enough to check the field is carried.
RANK = ConfidenceModel(
    kind="isotonic", names=("quantile",), coefficients=(0.0, 1.0), knots=(0.0, 1.0), values=(0, 1)
)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return replay(CORRIDOR, tmp_path_factory.mktemp("run") / "run.mcap", SMALL).output


@pytest.fixture(scope="module")
def bag(run, tmp_path_factory):
    out = tmp_path_factory.mktemp("bag") / "run_bag"
    rx.export_run_ros2(run, out, log=CORRIDOR, confidence=RANK)
    return out


def read_rosbags(path):
    """{topic: [(log time, msgtype, message)]} through rosbags' AnyReader."""
    found = {}
    store = get_typestore(Stores.ROS2_HUMBLE)
    with AnyReader([path], default_typestore=store) as reader:
        for conn, t, raw in reader.messages():
            found.setdefault(conn.topic, []).append(
                (t, conn.msgtype, reader.deserialize(raw, conn.msgtype))
            )
    return found


def read_mcap_ros2(path):
    """{topic: [(log time, message)]} through mcap-ros2-support's decoder."""
    found = {}
    (mcap,) = sorted(path.glob("*.mcap"))
    with open(mcap, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
            found.setdefault(channel.topic, []).append((message.log_time, decoded))
    return found


def cloud_fields(msg):
    """A PointCloud2 of float32 fields as {name: (N,) array}."""
    raw = np.frombuffer(bytes(msg.data), dtype="<f4").reshape(msg.width, -1)
    return {f.name: raw[:, f.offset // 4] for f in msg.fields}


def test_every_run_topic_is_written_with_its_standard_type(bag):
    types = {topic: rows[0][1] for topic, rows in read_rosbags(bag).items()}
    expected = {
        rx.FLIES: "sensor_msgs/msg/PointCloud2",
        rx.OBSTACLE_FLIES: "sensor_msgs/msg/PointCloud2",
        rx.DEPTH: "sensor_msgs/msg/Image",
        rx.DEPTH_CONFIDENCE: "sensor_msgs/msg/Image",
        rx.MAP: "nav_msgs/msg/OccupancyGrid",
        rx.POTENTIAL: "nav_msgs/msg/OccupancyGrid",
        rx.PLAN: "nav_msgs/msg/Path",
        rx.CMD_VEL: "geometry_msgs/msg/TwistStamped",
        rx.STATUS: "std_msgs/msg/String",
        rx.PLANNER_ODOM: "nav_msgs/msg/Odometry",
        # the sensor log's topics, as its own export writes them
        "/camera/left/image_rect_color": "sensor_msgs/msg/Image",
        "/odom": "nav_msgs/msg/Odometry",
        "/tf": "tf2_msgs/msg/TFMessage",
        "/tf_static": "tf2_msgs/msg/TFMessage",
    }
    assert {t: types.get(t) for t in expected} == expected


def test_flies_carry_the_runs_fields_and_times_in_both_readers(run, bag):
    snapshots = list(open_log(run).messages([contract.FLIES]))
    ours = read_rosbags(bag)[rx.FLIES]
    theirs = read_mcap_ros2(bag)[rx.FLIES]
    assert [t for t, _, _ in ours] == [m.log_time_ns for m in snapshots]
    assert [t for t, _ in theirs] == [m.log_time_ns for m in snapshots]
    for m, (_, _, a), (_, b) in zip(snapshots, ours, theirs, strict=True):
        cloud = m.value
        stamp = a.header.stamp.sec * 10**9 + a.header.stamp.nanosec
        assert stamp == m.log_time_ns and a.header.frame_id == contract.BASE_FRAME
        for msg in (a, b):
            fields = cloud_fields(msg)
            assert list(fields) == ["x", "y", "z", "fitness", "age", "distinct", "confidence"]
            np.testing.assert_array_equal(np.column_stack([fields[k] for k in "xyz"]), cloud.xyz)
            np.testing.assert_array_equal(fields["fitness"], cloud.fitness)
            np.testing.assert_array_equal(fields["age"], cloud.age)
            np.testing.assert_array_equal(fields["distinct"], cloud.distinct)
            np.testing.assert_array_equal(fields["confidence"], RANK.of_cloud(cloud))


def test_obstacle_flies_are_the_runs_rule(run, bag):
    reader = open_log(run)
    rule = run_facts(reader, MetricsConfig()).rule
    got = read_mcap_ros2(bag)[rx.OBSTACLE_FLIES]
    counts = []
    for m, (_, msg) in zip(reader.messages([contract.FLIES]), got, strict=True):
        c = m.value
        keep = rule.mask(c.xyz, c.fitness, c.age, c.distinct)
        np.testing.assert_array_equal(cloud_fields(msg)["x"], c.xyz[keep, 0])
        counts.append(int(keep.sum()))
    assert sum(counts) > 0


def test_map_potential_path_and_commands_match_the_run(run, bag):
    reader = open_log(run)
    ours = read_mcap_ros2(bag)
    maps = list(reader.messages([contract.PLANNER_MAP]))
    assert len(maps) == len(ours[rx.MAP]) > 0
    for m, (_, grid) in zip(maps, ours[rx.MAP], strict=True):
        values = m.value.values
        assert (grid.info.height, grid.info.width) == values.shape
        assert grid.info.resolution == pytest.approx(m.value.cell)
        assert grid.info.origin.position.x == m.value.origin.x
        np.testing.assert_array_equal(np.asarray(grid.data).reshape(values.shape), values)
    assert any((np.asarray(g.data) == 100).any() for _, g in ours[rx.MAP])
    for m, (_, grid) in zip(
        reader.messages([contract.PLANNER_POTENTIAL]), ours[rx.POTENTIAL], strict=True
    ):
        expected = np.rint(100 * np.clip(m.value.values.astype(float), 0, 1))
        np.testing.assert_array_equal(np.asarray(grid.data).reshape(expected.shape), expected)
    for m, (_, path) in zip(reader.messages([contract.PLANNER_PATH]), ours[rx.PLAN], strict=True):
        xy = np.array([[p.pose.position.x, p.pose.position.y] for p in path.poses]).reshape(-1, 2)
        np.testing.assert_array_equal(xy, m.value[:, :2])
        assert path.header.frame_id == contract.ODOM_FRAME
    commands = list(reader.messages([contract.PLANNER_COMMAND]))
    assert len(commands) == len(ours[rx.CMD_VEL]) == len(ours[rx.STATUS])
    for m, (t, twist), (_, status) in zip(commands, ours[rx.CMD_VEL], ours[rx.STATUS], strict=True):
        assert t == m.log_time_ns
        assert (twist.twist.linear.x, twist.twist.angular.z) == (
            m.value["linear"],
            m.value["angular"],
        )
        assert status.data == m.value["status"]


def test_depth_images_hold_the_flies_at_their_left_pixels(run, bag):
    rig = log_rig(open_log(CORRIDOR))
    got = read_mcap_ros2(bag)
    for m, (_, depth), (_, conf) in zip(
        open_log(run).messages([contract.FLIES]),
        got[rx.DEPTH],
        got[rx.DEPTH_CONFIDENCE],
        strict=True,
    ):
        assert (depth.encoding, depth.width, depth.height) == ("32FC1", rig.width, rig.height)
        image = np.frombuffer(bytes(depth.data), "<f4").reshape(rig.height, rig.width)
        weight = np.frombuffer(bytes(conf.data), "<f4").reshape(rig.height, rig.width)
        expected = sparse_depth(m.value.xyz, RANK.of_cloud(m.value), rig)
        np.testing.assert_array_equal(image, expected.depth)
        np.testing.assert_array_equal(weight, expected.weight)
        assert expected.filled > 0
        assert np.array_equal(np.isnan(image), weight == 0)


def test_without_the_log_the_run_writes_its_own_tf(run, tmp_path):
    out = tmp_path / "bag"
    summary = rx.export_run_ros2(run, out)
    found = read_rosbags(out)
    assert "/tf" in found and "/camera/left/image_rect_color" not in found
    assert "confidence" not in [f.name for f in found[rx.FLIES][0][2].fields]
    assert summary.messages == sum(len(v) for v in found.values())


def test_refusals_leave_nothing_behind(run, tmp_path):
    with pytest.raises(LogError, match="no run topics"):
        rx.export_run_ros2(CORRIDOR, tmp_path / "a")
    other = tmp_path / "other.mcap"
    other.write_bytes(CORRIDOR.read_bytes()[:-1000])  # another fingerprint
    with pytest.raises(LogError):
        rx.export_run_ros2(run, tmp_path / "b", log=other)
    (tmp_path / "c").mkdir()
    with pytest.raises(LogError, match="exists"):
        rx.export_run_ros2(run, tmp_path / "c")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c", "other.mcap"]


def test_cli_exports_a_run_and_a_log_to_ros2(run, tmp_path):
    runner = CliRunner()
    result = runner.invoke(cli, ["export", str(run), "--ros2", str(tmp_path / "r")])
    assert result.exit_code == 0, result.output
    assert rx.FLIES in read_rosbags(tmp_path / "r")
    result = runner.invoke(cli, ["export", str(run), "--ros2", str(tmp_path / "r2"), "--ply", "x"])
    assert result.exit_code == 2 and "exactly one of" in result.output
    result = runner.invoke(cli, ["export", str(run), "--tum", str(tmp_path / "t"), "--at", "1"])
    assert result.exit_code == 2 and "--at SECONDS picks" in result.output
    result = runner.invoke(cli, ["export", str(run), "--ply", str(tmp_path / "p")])
    assert result.exit_code == 0, result.output
    # the run has 400 flies, the model holds for the default 5000
    assert "another engine or obstacle configuration" in result.output
    export_ros2(CORRIDOR, tmp_path / "log_bag")  # the sensor log's export is unchanged
    assert rx.FLIES not in read_rosbags(tmp_path / "log_bag")


def test_a_run_exports_one_ply_a_snapshot_with_confidence(run, tmp_path):
    done = export_ply(run, tmp_path / "ply", confidence=RANK)
    snapshots = list(open_log(run).messages([contract.FLIES]))
    names = sorted(p.name for p in done.output.iterdir())
    assert names == [snapshot_name(m.log_time_ns) for m in snapshots] and done.files == len(names)
    for m in snapshots:
        vertex = PlyData.read(str(done.output / snapshot_name(m.log_time_ns)))["vertex"]
        cloud = m.value
        assert [p.name for p in vertex.properties] == [
            "x",
            "y",
            "z",
            "fitness",
            "age",
            "distinct",
            "confidence",
        ]
        np.testing.assert_array_equal(vertex["x"], cloud.xyz[:, 0])
        np.testing.assert_array_equal(vertex["fitness"], cloud.fitness)
        np.testing.assert_array_equal(vertex["confidence"], RANK.of_cloud(cloud))


def test_at_picks_the_nearest_snapshot_and_the_cli_writes_it(run, tmp_path):
    times = [m.log_time_ns for m in open_log(run).messages([contract.FLIES])]
    result = CliRunner().invoke(
        cli, ["export", str(run), "--ply", str(tmp_path / "one"), "--at", "0.61"]
    )
    assert result.exit_code == 0, result.output
    start = open_log(run).start_ns
    nearest = min(times, key=lambda t: abs(t - start - 610_000_000))
    assert [p.name for p in (tmp_path / "one").iterdir()] == [snapshot_name(nearest)]
    with pytest.raises(LogError, match="exists"):
        export_ply(run, tmp_path / "one")
    with pytest.raises(LogError, match="no /flies"):
        export_ply(CORRIDOR, tmp_path / "two")
    assert not (tmp_path / "two").exists()


def test_a_closed_loop_log_exports_its_flies_depth_and_tf_tree(tmp_path):
    scene = CORRIDOR.parents[1] / "scenes" / "corridor.toml"
    loop = tmp_path / "loop.mcap"
    args = ["simulate", str(scene), "--drive", "planner", "--duration", "1"]
    args += ["--resolution", "160x120", "-o", str(loop)]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    rx.export_run_ros2(loop, tmp_path / "bag")
    found = read_rosbags(tmp_path / "bag")
    assert len(found["/tf_static"]) == 1 and len(found["/tf"]) == len(found[rx.PLANNER_ODOM])
    assert len(found[rx.DEPTH]) == len(found[rx.FLIES]) > 0  # the rig from the log itself
    assert "/camera/left/image_rect_color" not in found
