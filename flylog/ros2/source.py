"""A ROS 2 bag as an input of replay: the rig, the start and the goal, and the stream of
sensor records (StereoPair, SonarReading, OdomReading) a flylog log gives, in log-time
order with bounded memory. ``/truth/`` topics are never read."""

from __future__ import annotations

import json
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from flylog.errors import LogError
from flylog.geometry import Pose2D, StereoRig
from flylog.geometry.calibrated import Mount
from flylog.io import contract
from flylog.io.pairing import UnpairedImagesWarning
from flylog.io.records import LogMessage
from flylog.ros2 import types
from flylog.ros2.bag import Bag, open_bag, static_tree
from flylog.ros2.calibration import CameraModel, camera_model, rectifier, rig_from_calibration
from flylog.ros2.config import BagOptions
from flylog.ros2.frames import frame_name, stamp_ns
from flylog.ros2.images import UnsupportedImage, image_of
from flylog.ros2.odometry import NoOdometryWarning, OdometryReader
from flylog.ros2.pairing import StereoPairing
from flylog.ros2.sonar import SonarRing, frame_of
from flylog.ros2.topics import Roles, assign_roles, parse_overrides

# custom_data key of a bag's goal (x, y in odom, JSON), as flylog's exporter writes it
GOAL_KEY = "flylog.goal"
SCENE_KEY = "flylog.scene"  # the scene file (TOML) of an exported simulation: ground truth
DEFAULT_FRAME_RATE = 15.0  # Hz, for a bag with a single image


class BagSource:
    """Opens a bag and works out what replay needs; :meth:`records` streams its records."""

    def __init__(self, path: str | Path, options: BagOptions) -> None:
        self.bag: Bag = open_bag(path)
        self.options = options
        self.roles: Roles = assign_roles(
            self.bag.path, self.bag.topics(), parse_overrides(options.topics)
        )
        self.unpaired = 0
        roles = self.roles
        self.cameras = {
            "left": self._first_camera(roles.left_info),
            "right": self._first_camera(roles.right_info),
        }
        self.tree = static_tree(self.bag)
        self.rig = self._rig()
        self._rectify = {side: rectifier(cam) for side, cam in self.cameras.items()}
        self.sonar_mounts = self._sonar_mounts()
        self.start = self._first_pose()

    @property
    def where(self) -> str:
        return str(self.bag.path)

    def _first(self, topic: str) -> Any:
        for m in self.bag.messages([topic]):
            return m.value
        msg = f"{self.where}: topic {topic} has no message that can be read"
        raise LogError(msg)

    def _first_camera(self, topic: str) -> CameraModel:
        try:
            return camera_model(self._first(topic))
        except LogError as exc:
            if str(exc).startswith(self.where):
                raise
            msg = f"{self.where}: {topic}: {exc}"
            raise LogError(msg) from None

    def _rig(self) -> StereoRig:
        """The rig from the two CameraInfos and the cameras' frames in /tf_static: the left
        frame must be there; the right one, when /tf_static has it and it is not the left
        one's, checks that the right camera sits where the right P puts it."""
        left, right = self.cameras["left"], self.cameras["right"]
        mount = self.tree.in_base(left.frame_id)
        if mount is None:
            msg = (
                f"{self.where}: /tf_static does not connect base_link to "
                f"'{left.frame_id}', the frame of {self.roles.left_info}: replay needs the "
                f"cameras' mount on the robot"
            )
            raise LogError(msg)
        right_mount = None
        if frame_name(right.frame_id) != frame_name(left.frame_id):
            found = self.tree.in_base(right.frame_id)
            right_mount = None if found is None else Mount(*found)
        return rig_from_calibration(
            left, right, (Mount(*mount), right_mount), self._frame_rate(),
            where=self.where,
            calibration=f"{self.roles.left_info} and {self.roles.right_info}",
            transforms=types.TF_STATIC,
        )  # fmt: skip

    def _frame_rate(self) -> float:
        """Left images per second over the bag's span (as for a flylog log)."""
        n = self.bag.topics()[self.roles.left].count
        span = self.bag.end_ns - self.bag.start_ns
        return 1e9 * (n - 1) / span if n > 1 and span > 0 else DEFAULT_FRAME_RATE

    def _sonar_mounts(self) -> np.ndarray:
        mounts = []
        for topic in self.roles.sonars:
            frame = frame_of(self._first(topic))
            mount = self.tree.mount(frame)
            if mount is None:
                msg = (
                    f"{self.where}: topic {topic}: /tf_static does not connect base_link and "
                    f"its frame '{frame}', so the sonar cannot be placed on the robot"
                )
                raise LogError(msg)
            mounts.append(mount)
        return np.array(mounts, dtype=float).reshape(-1, 3)

    def _odometry(self) -> OdometryReader:
        return OdometryReader(self.where, from_tf=self.roles.odom_from_tf, tree=self.tree)

    def _first_pose(self) -> Pose2D | None:
        """The first odometric pose, or None (with a warning) for a bag without odometry."""
        if self.roles.odom is not None:
            reader = self._odometry()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # warned when the stream reads it
                for m in self.bag.messages([self.roles.odom]):
                    for reading in reader.readings(m.value):
                        return reading.pose
        msg = (
            f"{self.where} has no odometry (no nav_msgs/msg/Odometry topic, no /tf odom → "
            f"base_link or to a frame /tf_static connects to base_link): replaying without "
            f"proprioception, the robot taken as standing at the origin"
        )
        warnings.warn(msg, NoOdometryWarning, stacklevel=2)
        return None

    @property
    def goal(self) -> tuple[float, float] | None:
        """The goal the bag's custom_data gives (flylog's exporter writes it), or None."""
        text = self.bag.custom.get(GOAL_KEY)
        if text is None:
            return None
        try:
            x, y = (float(v) for v in json.loads(text))
        except (ValueError, TypeError) as exc:
            msg = f"{self.where}: custom_data {GOAL_KEY} = {text!r} is not [x, y] ({exc})"
            raise LogError(msg) from None
        return (x, y)

    def _image(self, side: str, topic: str, m: Any) -> np.ndarray:
        camera = self.cameras[side]
        try:
            image = image_of(m.msgtype, m.value)
        except UnsupportedImage as exc:
            msg = f"{self.where}: topic {topic}: {exc}"
            raise LogError(msg) from None
        except LogError as exc:
            msg = f"{self.where}: topic {topic} at {m.log_time_ns} ns: {exc}"
            raise LogError(msg) from None
        h, w = image.shape[:2]
        if (w, h) != (camera.width, camera.height):
            info = self.roles.left_info if side == "left" else self.roles.right_info
            msg = (
                f"{self.where}: topic {topic} has {w}×{h} images but {info} calibrates "
                f"{camera.width}×{camera.height}"
            )
            raise LogError(msg)
        rectify = self._rectify[side]
        return image if rectify is None else rectify(image)

    def records(self) -> Iterator[LogMessage]:
        """The bag's sensor records as the flylog reader's stream gives them after stereo
        pairing: STEREO_PAIRS, SONAR and ODOM messages whose values are StereoPair,
        SonarReading and OdomReading. Unpaired images are counted in :attr:`unpaired`."""
        roles, opts = self.roles, self.options
        period_ns = 1e9 / self.rig.frame_rate
        pairing = StereoPairing(round(opts.pair_tolerance * period_ns))
        ring = SonarRing(roles.sonars, self.sonar_mounts, round(opts.sonar_window * 1e9))
        ring.where = self.where
        odometry = self._odometry()
        sides = {roles.left: "left", roles.right: "right"}
        sonars = set(roles.sonars)
        topics = [roles.left, roles.right, *roles.sonars]
        if roles.odom is not None:
            topics.append(roles.odom)
        for m in self.bag.messages(topics):
            t = m.log_time_ns
            side = sides.get(m.topic)
            if side is not None:
                image = self._image(side, m.topic, m)
                stamp = stamp_ns(m.value.header)
                for pair in pairing.add(side, stamp, image):
                    yield LogMessage(contract.STEREO_PAIRS, t, contract.STEREO_PAIR, pair)
            elif m.topic in sonars:
                for reading in ring.add(m.topic, m.value):
                    yield LogMessage(contract.SONAR, t, contract.SONAR_RANGES, reading)
            else:
                for odom in odometry.readings(m.value):
                    yield LogMessage(contract.ODOM, t, contract.POSE_IN_FRAME, odom)
        for reading in ring.finish():
            yield LogMessage(contract.SONAR, self.bag.end_ns, contract.SONAR_RANGES, reading)
        pairing.finish()
        self.unpaired = pairing.dropped
        if self.unpaired:
            msg = (
                f"{self.where}: {self.unpaired} images of {roles.left} and {roles.right} had no "
                f"partner within {opts.pair_tolerance:g} frame periods and were dropped"
            )
            warnings.warn(msg, UnpairedImagesWarning, stacklevel=2)
