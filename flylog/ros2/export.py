"""``flylog export LOG --ros2 OUT``: a flylog sensor log as a rosbag2 directory (MCAP
storage) of standard messages, written atomically.

| flylog topic | ROS 2 topic | type |
|---|---|---|
| /camera/{side}/image | /camera/{side}/image_rect_color | sensor_msgs/msg/Image |
| (png, jpeg) | /camera/{side}/image_rect_color/compressed | sensor_msgs/msg/CompressedImage |
| /camera/{side}/calibration | /camera/{side}/camera_info | sensor_msgs/msg/CameraInfo |
| /sonar | /sonar/range_{i}, one per sonar | sensor_msgs/msg/Range |
| /odom | /odom | nav_msgs/msg/Odometry |
| /tf (odom → base_link) | /tf | tf2_msgs/msg/TFMessage |
| /tf (base_link → cameras, sonars) | /tf_static, once, transient-local | tf2_msgs/msg/TFMessage |
| /truth/pose (``--truth``) | /truth/odom | nav_msgs/msg/Odometry |

Every message keeps its log time and its own stamp. The goal of the log's mission goes
into metadata.yaml's custom_data (``flylog.goal``), so replay finds it as in the log; with
``truth``, the scene file too (``flylog.scene``), so metrics finds the ground truth.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from mcap_protobuf.decoder import DecoderFactory

from flylog.errors import LogError, OutputError
from flylog.io import contract, open_log
from flylog.io.atomic import part_stem
from flylog.io.decode import image as rgb_of
from flylog.io.decode import stamp_ns
from flylog.ros2 import types
from flylog.ros2.bagwriter import open_bag_writer
from flylog.ros2.messages import TF_STATIC_QOS, Builder, ImageFormat
from flylog.ros2.source import GOAL_KEY, SCENE_KEY

SCENE_ATTACHMENT = "scene.toml"  # a flylog sensor log's scene file

ODOM_TOPIC = "/odom"
TRUTH_ODOM = "/truth/odom"


def image_topic(side: str, fmt: ImageFormat) -> str:
    base = f"/camera/{side}/image_rect_color"
    return f"{base}/compressed" if fmt.compressed else base


def info_topic(side: str) -> str:
    return f"/camera/{side}/camera_info"


def range_topic(index: int) -> str:
    return f"/sonar/range_{index}"


@dataclass(frozen=True)
class ExportSummary:
    output: Path
    messages: int
    topics: int


class _Bag:
    """A rosbags writer with connections made on first use."""

    def __init__(self, path: Path) -> None:
        self.store = types.standard_typestore()
        self.build = Builder(self.store)
        self.writer = open_bag_writer(path)
        self._connections: dict[str, Any] = {}
        self.count = 0

    def write(self, topic: str, log_time_ns: int, msgtype: str, message: Any) -> None:
        connection = self._connections.get(topic)
        if connection is None:
            qos = (TF_STATIC_QOS,) if topic == types.TF_STATIC else ()
            connection = self._connections[topic] = self.writer.add_connection(
                topic, msgtype, typestore=self.store, offered_qos_profiles=qos
            )
        self.writer.write(connection, log_time_ns, self.store.serialize_cdr(message, msgtype))
        self.count += 1

    @property
    def topics(self) -> int:
        return len(self._connections)


def export_ros2(
    log: str | os.PathLike[str],
    output: str | os.PathLike[str],
    *,
    image_format: ImageFormat = ImageFormat.RGB8,
    truth: bool = False,
    on_progress: Callable[[float, float], None] | None = None,
) -> ExportSummary:
    """Write the sensor topics of ``log`` (and with ``truth`` its true pose) as the rosbag2
    directory ``output``; nothing is left behind on failure."""
    log, output = Path(log), Path(output)
    if output.exists():
        msg = f"{output} exists: the ROS 2 export writes a new directory"
        raise OutputError(msg, path=output)
    if not output.parent.is_dir():
        msg = f"cannot write {output}: directory {output.parent} does not exist"
        raise LogError(msg)
    reader = open_log(log)
    goal = reader.metadata().get(contract.SIMULATION_METADATA, {}).get("goal")
    # part_stem: a name of any legal length leaves room for mkdtemp's 8 characters
    prefix = f"{part_stem(output)}."
    staging = Path(tempfile.mkdtemp(prefix=prefix, suffix=".part", dir=output.parent))
    try:
        bag = _Bag(staging / output.name)
        if goal is not None:
            bag.writer.set_custom_data(GOAL_KEY, json.dumps(json.loads(goal)))
        for attachment in reader.attachments() if truth else ():
            if attachment.name == SCENE_ATTACHMENT:
                bag.writer.set_custom_data(SCENE_KEY, attachment.data.decode("utf-8"))
        with bag.writer:
            _Translation(bag, image_format).run(reader, truth, on_progress)
        os.replace(staging / output.name, output)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return ExportSummary(output, bag.count, bag.topics)


class _Translation:
    """The flylog log's messages, one by one, as ROS 2 messages."""

    def __init__(self, bag: _Bag, image_format: ImageFormat) -> None:
        self.bag = bag
        self.fmt = image_format
        self.protobuf = DecoderFactory()
        self.decoders: dict[int, Callable[[bytes], Any]] = {}
        self.static_written = False

    def _decode(self, raw: Any) -> Any:
        channel = raw.channel
        if channel.message_encoding == contract.JSON_MESSAGE_ENCODING:
            return json.loads(bytes(raw.message.data))
        decoder = self.decoders.get(channel.id)
        if decoder is None:
            decoder = self.protobuf.decoder_for(channel.message_encoding, raw.schema)
            if decoder is None:
                msg = f"topic {channel.topic} has an encoding flylog cannot decode"
                raise LogError(msg)
            self.decoders[channel.id] = decoder
        return decoder(bytes(raw.message.data))

    def run(
        self, reader: Any, truth: bool, on_progress: Callable[[float, float], None] | None
    ) -> None:
        topics = [
            *contract.IMAGE_TOPICS.values(), *contract.CALIBRATION_TOPICS.values(),
            contract.SONAR, contract.ODOM, contract.TF, *([contract.TRUTH_POSE] if truth else []),
        ]  # fmt: skip
        present = set(reader.topics())
        if not {contract.LEFT_IMAGE, contract.RIGHT_IMAGE} <= present:
            msg = f"{reader.path} has no {contract.LEFT_IMAGE} and {contract.RIGHT_IMAGE}"
            raise LogError(msg)
        t0, span = reader.start_ns, max(1, reader.end_ns - reader.start_ns)
        handlers = {
            contract.SONAR: self._sonar, contract.ODOM: self._odom, contract.TF: self._tf,
            contract.TRUTH_POSE: self._truth,
        }  # fmt: skip
        for i, raw in enumerate(reader.raw_messages([t for t in topics if t in present])):
            t, topic = raw.message.log_time, raw.channel.topic
            try:
                value = self._decode(raw)
            except LogError:
                raise
            except Exception as exc:
                msg = f"{reader.path}: cannot decode {topic} at {t} ns ({exc})"
                raise LogError(msg) from None
            side = _side(topic)
            if topic in contract.IMAGE_TOPICS.values():
                self._image(side, t, value)
            elif topic in contract.CALIBRATION_TOPICS.values():
                self._calibration(side, t, value)
            else:
                handlers[topic](t, value)
            if on_progress is not None and i % 64 == 0:
                on_progress((t - t0) / 1e9, span / 1e9)

    def _image(self, side: str, t: int, msg: Any) -> None:
        message = self.bag.build.image(rgb_of(msg), stamp_ns(msg.timestamp), msg.frame_id, self.fmt)
        self.bag.write(image_topic(side, self.fmt), t, self.fmt.msgtype, message)

    def _calibration(self, side: str, t: int, msg: Any) -> None:
        message = self.bag.build.camera_info(
            stamp_ns(msg.timestamp), msg.frame_id, (msg.width, msg.height), list(msg.K),
            list(msg.P), d=list(msg.D) or [0.0] * 5, r=list(msg.R) or np.eye(3).ravel().tolist(),
            model=msg.distortion_model or "plumb_bob",
        )  # fmt: skip
        self.bag.write(info_topic(side), t, types.CAMERA_INFO, message)

    def _sonar(self, t: int, data: dict[str, Any]) -> None:
        stamp = stamp_ns(data["timestamp"])
        for i, value in enumerate(data["ranges"]):
            message = self.bag.build.range(
                stamp, contract.sonar_frame(i), float("nan") if value is None else value,
                data["cone_angle"], data.get("min_range", 0.0), data["max_range"],
            )  # fmt: skip
            self.bag.write(range_topic(i), t, types.RANGE, message)

    def _pose_odometry(self, topic: str, t: int, msg: Any) -> None:
        p, q = msg.pose.position, msg.pose.orientation
        message = self.bag.build.odometry(
            stamp_ns(msg.timestamp), (p.x, p.y, p.z), (q.x, q.y, q.z, q.w), contract.BASE_FRAME
        )
        self.bag.write(topic, t, types.ODOMETRY, message)

    def _odom(self, t: int, msg: Any) -> None:
        self._pose_odometry(ODOM_TOPIC, t, msg)

    def _truth(self, t: int, msg: Any) -> None:
        self._pose_odometry(TRUTH_ODOM, t, msg)

    def _tf(self, t: int, msg: Any) -> None:
        static: list[Any] = []
        moving: list[Any] = []
        stamp = t
        for tr in msg.transforms:
            stamp = stamp_ns(tr.timestamp)
            v, q = tr.translation, tr.rotation
            row = (tr.parent_frame_id, tr.child_frame_id, (v.x, v.y, v.z), (q.x, q.y, q.z, q.w))
            (moving if tr.parent_frame_id == contract.ODOM_FRAME else static).append(row)
        if static and not self.static_written:
            self.bag.write(types.TF_STATIC, t, types.TF_MESSAGE, self.bag.build.tf(stamp, static))
            self.static_written = True
        if moving:
            self.bag.write(types.TF, t, types.TF_MESSAGE, self.bag.build.tf(stamp, moving))


def _side(topic: str) -> str:
    return "left" if "/left/" in topic else "right"
