"""Small ROS 2 bags for tests, written with rosbags' own writer and typestore (not with
flylog's exporter): a textured fronto-parallel plane seen by a rectified rig, at a known
depth, with CameraInfo, /tf_static, Range and Odometry as a robot's drivers publish them."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

STORE = get_typestore(Stores.ROS2_HUMBLE)
T = STORE.types
W, H = 64, 48
FOCAL = 40.0
BASELINE = 0.1
MOUNT = (0.2, BASELINE / 2, 0.4)  # left optical centre in base_link
DEPTH = 2.0  # m, of the textured plane
PERIOD_NS = 100_000_000  # 10 Hz cameras
OPTICAL_Q = (-0.5, 0.5, -0.5, 0.5)  # optical frame (z forward) in base_link (x forward)


def header(t_ns: int, frame: str) -> Any:
    sec, nsec = divmod(t_ns, 1_000_000_000)
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec), frame_id=frame
    )


def texture(seed: int = 0, width: int = W + 16) -> np.ndarray:
    """A smooth random RGB texture (H, width, 3) uint8."""
    import cv2

    rng = np.random.default_rng(seed)
    noise = rng.uniform(0, 255, (H // 4, width // 4, 3)).astype(np.float32)
    return (
        np.asarray(cv2.resize(noise, (width, H), interpolation=cv2.INTER_CUBIC))
        .clip(0, 255)
        .astype(np.uint8)
    )


def stereo_views(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Left and right rectified images of the plane: right = left shifted by f·B/Z px."""
    tex = texture(seed)
    shift = round(FOCAL * BASELINE / DEPTH)  # 2 px
    return tex[:, 8 : 8 + W].copy(), tex[:, 8 + shift : 8 + shift + W].copy()


def k_matrix(cx: float = (W - 1) / 2, cy: float = (H - 1) / 2) -> np.ndarray:
    return np.array([FOCAL, 0, cx, 0, FOCAL, cy, 0, 0, 1], dtype=np.float64)


def p_matrix(tx: float = 0.0, cx: float = (W - 1) / 2, cy: float = (H - 1) / 2) -> np.ndarray:
    return np.array([FOCAL, 0, cx, tx, 0, FOCAL, cy, 0, 0, 0, 1, 0], dtype=np.float64)


def camera_info(t_ns: int, frame: str, tx: float, **kw: Any) -> Any:
    size = kw.pop("size", (W, H))
    return T["sensor_msgs/msg/CameraInfo"](
        header=header(t_ns, frame), height=size[1], width=size[0],
        distortion_model=kw.pop("model", "plumb_bob"),
        d=np.asarray(kw.pop("d", np.zeros(5)), dtype=np.float64),
        k=np.asarray(kw.pop("k", k_matrix()), dtype=np.float64),
        r=np.asarray(kw.pop("r", np.eye(3).ravel()), dtype=np.float64),
        p=np.asarray(kw.pop("p", p_matrix(tx)), dtype=np.float64),
        binning_x=0, binning_y=0,
        roi=T["sensor_msgs/msg/RegionOfInterest"](
            x_offset=0, y_offset=0, height=0, width=0, do_rectify=False
        ),
    )  # fmt: skip


def image(t_ns: int, frame: str, pixels: np.ndarray, encoding: str = "rgb8") -> Any:
    flat = np.ascontiguousarray(pixels)
    return T["sensor_msgs/msg/Image"](
        header=header(t_ns, frame), height=flat.shape[0], width=flat.shape[1],
        encoding=encoding, is_bigendian=0, step=flat.strides[0],
        data=flat.view(np.uint8).reshape(-1),
    )  # fmt: skip


def compressed(t_ns: int, frame: str, rgb: np.ndarray, fmt: str) -> Any:
    import cv2

    ok, data = cv2.imencode(f".{fmt}", np.ascontiguousarray(rgb[..., ::-1]))
    assert ok
    return T["sensor_msgs/msg/CompressedImage"](
        header=header(t_ns, frame), format=fmt, data=np.asarray(data, np.uint8).ravel()
    )


def transform(t_ns: int, parent: str, child: str, xyz: tuple, q: tuple) -> Any:
    v = T["geometry_msgs/msg/Vector3"](x=xyz[0], y=xyz[1], z=xyz[2])
    r = T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3])
    return T["geometry_msgs/msg/TransformStamped"](
        header=header(t_ns, parent), child_frame_id=child,
        transform=T["geometry_msgs/msg/Transform"](translation=v, rotation=r),
    )  # fmt: skip


def tf_message(transforms: list[Any]) -> Any:
    return T["tf2_msgs/msg/TFMessage"](transforms=transforms)


def yaw_q(yaw: float, roll: float = 0.0) -> tuple[float, float, float, float]:
    """x, y, z, w of Rz(yaw)·Rx(roll)."""
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    return (cy * sr, sy * sr, cr * sy, cy * cr)


def turned_q(pan: float = 0.0, tilt: float = 0.0, roll: float = 0.0) -> tuple:
    """x, y, z, w of Rz(pan)·Ry(tilt)·Rx(roll) (radians) applied to the level optical
    frame: a camera panned left, tilted down and rolled."""

    def mul(a: tuple, b: tuple) -> tuple:
        (ax, ay, az, aw), (bx, by, bz, bw) = a, b
        return (
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        )

    def about(axis: int, angle: float) -> tuple:
        q = [0.0, 0.0, 0.0, math.cos(angle / 2)]
        q[axis] = math.sin(angle / 2)
        return tuple(q)

    return mul(about(2, pan), mul(about(1, tilt), mul(about(0, roll), OPTICAL_Q)))


def odometry(t_ns: int, x: float, y: float, yaw: float, roll: float = 0.0) -> Any:
    q = yaw_q(yaw, roll)
    pose = T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
        orientation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]),
    )
    zero = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
    return T["nav_msgs/msg/Odometry"](
        header=header(t_ns, "odom"), child_frame_id="base_link",
        pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](
            twist=T["geometry_msgs/msg/Twist"](linear=zero, angular=zero),
            covariance=np.zeros(36),
        ),
    )  # fmt: skip


def range_msg(t_ns: int, frame: str, value: float, lo: float = 0.05, hi: float = 3.0) -> Any:
    return T["sensor_msgs/msg/Range"](
        header=header(t_ns, frame), radiation_type=0, field_of_view=math.radians(15),
        min_range=lo, max_range=hi, range=value,
    )  # fmt: skip


Message = tuple[str, str, int, Any]  # topic, type, log time, message


@dataclass
class BagSpec:
    """What a test bag holds; edit the fields, then :func:`write_bag`."""

    frames: int = 4
    left: str = "/stereo/left/image_rect"
    right: str = "/stereo/right/image_rect"
    encoding: str = "rgb8"
    sonars: tuple[float, ...] = (0.0,)  # mount yaw of each sonar
    odom: bool = True
    extra: list[Message] = field(default_factory=list)
    image_of: Callable[[str, np.ndarray], np.ndarray] | None = None  # side, rgb → pixels
    right_delay_ns: int = 0
    camera_q: tuple[float, float, float, float] = OPTICAL_Q  # left optical frame in base_link
    principal_point: tuple[float, float] = ((W - 1) / 2, (H - 1) / 2)  # left camera's (px)
    doffs: float = 0.0  # right cx − left cx (px)
    right_mount: tuple[float, float, float] | None = None  # camera_right in /tf_static


def messages(spec: BagSpec) -> list[Message]:
    left_img, right_img = stereo_views()
    out: list[Message] = []
    statics = [transform(0, "base_link", "camera_left", MOUNT, spec.camera_q)]
    if spec.right_mount is not None:
        statics.append(transform(0, "base_link", "camera_right", spec.right_mount, spec.camera_q))
    for i, yaw in enumerate(spec.sonars):
        xyz = (0.2 * math.cos(yaw), 0.2 * math.sin(yaw), 0.3)
        statics.append(transform(0, "base_link", f"sonar_{i}", xyz, yaw_q(yaw)))
    out.append(("/tf_static", "tf2_msgs/msg/TFMessage", 0, tf_message(statics)))
    ns = {"left": spec.left.rsplit("/", 1)[0], "right": spec.right.rsplit("/", 1)[0]}
    for k in range(spec.frames):
        t = k * PERIOD_NS
        if spec.odom:
            out.append(("/odom", "nav_msgs/msg/Odometry", t, odometry(t, 0.01 * k, 0.0, 0.0)))
        for i, _ in enumerate(spec.sonars):
            msg = range_msg(t, f"sonar_{i}", 1.0 + 0.1 * i)
            out.append((f"/sonar_{i}", "sensor_msgs/msg/Range", t, msg))
        for side, topic, pixels in (
            ("left", spec.left, left_img),
            ("right", spec.right, right_img),
        ):
            ts = t + (spec.right_delay_ns if side == "right" else 0)
            tx = 0.0 if side == "left" else -FOCAL * BASELINE
            cx, cy = spec.principal_point
            cx += spec.doffs if side == "right" else 0.0
            info = camera_info(ts, f"camera_{side}", tx, k=k_matrix(cx, cy), p=p_matrix(tx, cx, cy))
            out.append((f"{ns[side]}/camera_info", "sensor_msgs/msg/CameraInfo", ts, info))
            data = pixels if spec.image_of is None else spec.image_of(side, pixels)
            if spec.encoding in ("jpeg", "png"):
                msg = compressed(ts, f"camera_{side}", data, spec.encoding)
                out.append((topic, "sensor_msgs/msg/CompressedImage", ts, msg))
            else:
                msg = image(ts, f"camera_{side}", data, spec.encoding)
                out.append((topic, "sensor_msgs/msg/Image", ts, msg))
    out.extend(spec.extra)
    out.sort(key=lambda m: m[2])
    return out


def write_bag(
    path: Path,
    items: list[Message],
    *,
    serialize: Callable | None = None,
    custom: dict[str, str] | None = None,
) -> Path:
    """A rosbag2 directory of ``items`` written by rosbags (``serialize(topic, bytes)`` may
    alter a message's bytes; ``custom``: metadata.yaml's custom_data)."""
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        for key, value in (custom or {}).items():
            writer.set_custom_data(key, value)
        connections: dict[str, Any] = {}
        for topic, msgtype, t_ns, msg in items:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=STORE)
            data = bytes(STORE.serialize_cdr(msg, msgtype))
            if serialize is not None:
                data = serialize(topic, data)
            writer.write(connections[topic], t_ns, data)
    return path


def make_bag(path: Path, spec: BagSpec | None = None) -> Path:
    return write_bag(path, messages(spec or BagSpec()))
