"""Standard ROS 2 messages built from plain values, as ``rosbags`` objects of the standard
typestore (:data:`flylog.ros2.types.STANDARD_STORE`), and the QoS profile of
``/tf_static``."""

from __future__ import annotations

import enum
from collections.abc import Sequence
from typing import Any

import numpy as np
from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.typesys.store import Typestore

from flylog.ros2 import types

ULTRASOUND = 0  # sensor_msgs/msg/Range.ULTRASOUND
JPEG_QUALITY = 95  # OpenCV's scale, 0-100


class ImageFormat(enum.Enum):
    """How the exporter writes images."""

    RGB8 = "rgb8"
    BGR8 = "bgr8"
    PNG = "png"
    JPEG = "jpeg"

    @property
    def compressed(self) -> bool:
        return self in (ImageFormat.PNG, ImageFormat.JPEG)

    @property
    def msgtype(self) -> str:
        return types.COMPRESSED_IMAGE if self.compressed else types.IMAGE


# What ROS 2's static_transform_publisher offers on /tf_static (rclcpp's StaticBroadcaster
# QoS): reliable, transient-local, keep the last message; late subscribers to a replayed
# bag get the static tree.
TF_STATIC_QOS = Qos(
    history=QosHistory.KEEP_LAST,
    depth=1,
    reliability=QosReliability.RELIABLE,
    durability=QosDurability.TRANSIENT_LOCAL,
    deadline=QosTime(0, 0),
    lifespan=QosTime(0, 0),
    liveliness=QosLiveliness.AUTOMATIC,
    liveliness_lease_duration=QosTime(0, 0),
    avoid_ros_namespace_conventions=False,
)


class Builder:
    """Makes messages of the standard types."""

    def __init__(self, store: Typestore) -> None:
        self.store = store
        self._t = store.types

    def header(self, stamp_ns: int, frame_id: str) -> Any:
        sec, nsec = divmod(int(stamp_ns), 1_000_000_000)
        time = self._t["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec)
        return self._t["std_msgs/msg/Header"](stamp=time, frame_id=frame_id)

    def image(self, rgb: np.ndarray, stamp_ns: int, frame_id: str, fmt: ImageFormat) -> Any:
        """(H, W, 3) RGB or (H, W) grey uint8 → Image (rgb8/bgr8/mono8) or CompressedImage."""
        header = self.header(stamp_ns, frame_id)
        grey = rgb.ndim == 2
        if fmt.compressed:
            import cv2

            bgr = rgb if grey else np.ascontiguousarray(rgb[..., ::-1])
            params = [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY] if fmt is ImageFormat.JPEG else []
            ok, data = cv2.imencode(f".{fmt.value}", bgr, params)
            assert ok, "OpenCV encodes any uint8 image"
            return self._t[types.COMPRESSED_IMAGE](
                header=header, format=fmt.value, data=np.asarray(data, np.uint8).ravel()
            )
        if grey:
            pixels, encoding = rgb, "mono8"
        elif fmt is ImageFormat.BGR8:
            pixels, encoding = rgb[..., ::-1], "bgr8"
        else:
            pixels, encoding = rgb, "rgb8"
        h, w = rgb.shape[:2]
        channels = 1 if grey else 3
        return self._t[types.IMAGE](
            header=header,
            height=h,
            width=w,
            encoding=encoding,
            is_bigendian=0,
            step=w * channels,
            data=np.ascontiguousarray(pixels).reshape(-1),
        )

    def camera_info(
        self,
        stamp_ns: int,
        frame_id: str,
        size: tuple[int, int],
        k: Sequence[float],
        p: Sequence[float],
        *,
        d: Sequence[float] = (0.0,) * 5,
        r: Sequence[float] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        model: str = "plumb_bob",
    ) -> Any:
        roi = self._t["sensor_msgs/msg/RegionOfInterest"](
            x_offset=0, y_offset=0, height=0, width=0, do_rectify=False
        )
        return self._t[types.CAMERA_INFO](
            header=self.header(stamp_ns, frame_id),
            height=int(size[1]),
            width=int(size[0]),
            distortion_model=model,
            d=np.asarray(d, dtype=np.float64),
            k=np.asarray(k, dtype=np.float64),
            r=np.asarray(r, dtype=np.float64),
            p=np.asarray(p, dtype=np.float64),
            binning_x=0,
            binning_y=0,
            roi=roi,
        )

    def range(
        self, stamp_ns: int, frame_id: str, value: float, cone: float, lo: float, hi: float
    ) -> Any:
        """A Range; NaN (no echo) is written as +inf (REP 117)."""
        return self._t[types.RANGE](
            header=self.header(stamp_ns, frame_id),
            radiation_type=ULTRASOUND,
            field_of_view=float(cone),
            min_range=float(lo),
            max_range=float(hi),
            range=float("inf") if np.isnan(value) else float(value),
        )

    def _vector(self, x: float, y: float, z: float) -> Any:
        return self._t["geometry_msgs/msg/Vector3"](x=float(x), y=float(y), z=float(z))

    def _quaternion(self, q: Sequence[float]) -> Any:
        x, y, z, w = (float(v) for v in q)
        return self._t["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)

    def odometry(
        self, stamp_ns: int, position: Sequence[float], rotation: Sequence[float], child: str
    ) -> Any:
        """An Odometry in ``odom`` with no twist and zero covariances."""
        t = self._t
        point = t["geometry_msgs/msg/Point"](*(float(v) for v in position))
        pose = t["geometry_msgs/msg/Pose"](position=point, orientation=self._quaternion(rotation))
        twist = t["geometry_msgs/msg/Twist"](
            linear=self._vector(0, 0, 0), angular=self._vector(0, 0, 0)
        )
        zeros = np.zeros(36, dtype=np.float64)
        return t[types.ODOMETRY](
            header=self.header(stamp_ns, "odom"),
            child_frame_id=child,
            pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=zeros),
            twist=t["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=zeros.copy()),
        )

    def tf(
        self, stamp_ns: int, transforms: Sequence[tuple[str, str, Sequence[float], Sequence[float]]]
    ) -> Any:
        """A TFMessage of (parent, child, translation, rotation xyzw) transforms."""
        t = self._t
        stamped = [
            t["geometry_msgs/msg/TransformStamped"](
                header=self.header(stamp_ns, parent),
                child_frame_id=child,
                transform=t["geometry_msgs/msg/Transform"](
                    translation=self._vector(*translation), rotation=self._quaternion(rotation)
                ),
            )
            for parent, child, translation, rotation in transforms
        ]
        return t[types.TF_MESSAGE](transforms=stamped)
