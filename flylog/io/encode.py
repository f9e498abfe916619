"""Encoders: pure functions from numpy arrays and flylog records to the messages of the
contract (Foxglove protobuf messages, or dicts for the JSON topics)."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import foxglove.messages as fm
import numpy as np

from flylog.geometry import Pose2D, StereoRig, yaw_quaternion
from flylog.io import contract
from flylog.io import protobuf_wire as wire
from flylog.io.records import BoxShape, CylinderShape, Transform
from flylog.sensors import SonarConfig, SonarReading

_F32 = fm.PackedElementFieldNumericType.Float32


def timestamp(stamp_ns: int) -> fm.Timestamp:
    """A Foxglove timestamp from integer nanoseconds (which must not be negative)."""
    sec, nsec = _split_ns(stamp_ns)
    return fm.Timestamp(sec, nsec)


def json_time(stamp_ns: int) -> dict[str, int]:
    """Foxglove's JSON time object ``{"sec", "nsec"}``."""
    sec, nsec = _split_ns(stamp_ns)
    return {"sec": sec, "nsec": nsec}


def _split_ns(stamp_ns: int) -> tuple[int, int]:
    stamp_ns = int(stamp_ns)
    if stamp_ns < 0:
        msg = f"message times must not be negative, got {stamp_ns} ns"
        raise ValueError(msg)
    return divmod(stamp_ns, 1_000_000_000)


def _pose(x: float, y: float, z: float, rotation: Sequence[float]) -> fm.Pose:
    qx, qy, qz, qw = (float(q) for q in rotation)
    return fm.Pose(
        position=fm.Vector3(x=float(x), y=float(y), z=float(z)),
        orientation=fm.Quaternion(x=qx, y=qy, z=qz, w=qw),
    )


def _planar_pose(pose: Pose2D) -> fm.Pose:
    return _pose(pose.x, pose.y, 0.0, yaw_quaternion(pose.theta))


def _colour(rgba: Sequence[float]) -> fm.Color:
    r, g, b, a = (float(c) for c in rgba)
    return fm.Color(r=r, g=g, b=b, a=a)


def raw_image(image: np.ndarray, stamp_ns: int, frame_id: str) -> fm.RawImage:
    """(H, W, 3) uint8 RGB → "rgb8", (H, W) uint8 → "mono8"."""
    image = np.asarray(image)
    if image.dtype != np.uint8 or not (
        image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)
    ):
        msg = f"images must be (H, W, 3) or (H, W) uint8, got {image.shape} {image.dtype}"
        raise ValueError(msg)
    height, width = image.shape[:2]
    encoding = "mono8" if image.ndim == 2 else "rgb8"
    return fm.RawImage(
        timestamp=timestamp(stamp_ns),
        frame_id=frame_id,
        width=width,
        height=height,
        encoding=encoding,
        step=width * (1 if image.ndim == 2 else 3),
        data=image.tobytes(),  # tobytes() is C order whatever the array's layout
    )


def disparity_image(disparity: np.ndarray, stamp_ns: int, frame_id: str) -> fm.RawImage:
    """(H, W) values (a ground-truth disparity, NaN unknown) → "32FC1", little endian."""
    values = np.ascontiguousarray(disparity, dtype="<f4")
    if values.ndim != 2:
        msg = f"a disparity image is (H, W), got {values.shape}"
        raise ValueError(msg)
    height, width = values.shape
    return fm.RawImage(
        timestamp=timestamp(stamp_ns),
        frame_id=frame_id,
        width=width,
        height=height,
        encoding="32FC1",
        step=width * 4,
        data=values.tobytes(),
    )


def camera_calibration(rig: StereoRig, side: str, stamp_ns: int) -> fm.CameraCalibration:
    """The rectified calibration of one camera: no distortion, R = I, the left camera as
    the stereo reference (the right P carries −fx·baseline)."""
    if side not in contract.CAMERA_FRAMES:
        msg = f"side must be 'left' or 'right', got {side!r}"
        raise ValueError(msg)
    return fm.CameraCalibration(
        timestamp=timestamp(stamp_ns),
        frame_id=contract.CAMERA_FRAMES[side],
        width=rig.width,
        height=rig.height,
        distortion_model="plumb_bob",
        D=[0.0] * 5,
        K=[float(v) for v in rig.intrinsics(side).ravel()],
        R=[float(v) for v in np.eye(3).ravel()],
        P=[float(v) for v in rig.projection(side).ravel()],
    )


def pose_in_frame(pose: Pose2D, stamp_ns: int, frame_id: str) -> fm.PoseInFrame:
    """A planar pose (z = 0, yaw about z)."""
    return fm.PoseInFrame(timestamp=timestamp(stamp_ns), frame_id=frame_id, pose=_planar_pose(pose))


def frame_transforms(transforms: Iterable[Transform], stamp_ns: int) -> fm.FrameTransforms:
    ts = timestamp(stamp_ns)
    return fm.FrameTransforms(
        transforms=[
            fm.FrameTransform(
                timestamp=ts,
                parent_frame_id=t.parent,
                child_frame_id=t.child,
                translation=fm.Vector3(
                    x=float(t.translation[0]), y=float(t.translation[1]), z=float(t.translation[2])
                ),
                rotation=fm.Quaternion(
                    x=float(t.rotation[0]),
                    y=float(t.rotation[1]),
                    z=float(t.rotation[2]),
                    w=float(t.rotation[3]),
                ),
            )
            for t in transforms
        ]
    )


def odom_transform(pose: Pose2D) -> Transform:
    """odom → base_link for the robot at ``pose``."""
    return Transform(
        contract.ODOM_FRAME, contract.BASE_FRAME, (pose.x, pose.y, 0.0), yaw_quaternion(pose.theta)
    )


def static_transforms(rig: StereoRig, sonar: SonarConfig) -> list[Transform]:
    """base_link → camera_left/right (optical frames) and base_link → sonar_i (x along the
    beam), from the rig and the sonar ring."""
    out = [
        Transform(
            contract.BASE_FRAME,
            contract.CAMERA_FRAMES[side],
            rig.camera_position(side),
            rig.mount_quaternion(),
        )
        for side in ("left", "right")
    ]
    for i, (x, y, yaw) in enumerate(sonar.mounts()):
        out.append(
            Transform(
                contract.BASE_FRAME,
                contract.sonar_frame(i),
                (float(x), float(y), sonar.mount_height),
                yaw_quaternion(float(yaw)),
            )
        )
    return out


def sonar_ranges(reading: SonarReading, *, min_range: float) -> dict[str, Any]:
    """A ``flylog.SonarRanges`` message (NaN ranges become null)."""
    ranges = np.asarray(reading.ranges, dtype=float)
    return {
        "timestamp": json_time(reading.stamp_ns),
        "frame_id": contract.BASE_FRAME,
        "ranges": [None if math.isnan(r) else float(r) for r in ranges],
        "fired": [bool(f) for f in ~np.isnan(ranges)],
        "cone_angle": float(reading.cone_angle),
        "max_range": float(reading.max_range),
        "min_range": float(min_range),
        "mounts": [[float(v) for v in row] for row in np.asarray(reading.mounts, dtype=float)],
    }


def command(
    linear: float, angular: float, status: contract.CommandStatus, stamp_ns: int
) -> dict[str, Any]:
    """A ``flylog.Command`` message."""
    return {
        "timestamp": json_time(stamp_ns),
        "linear": float(linear),
        "angular": float(angular),
        "status": contract.CommandStatus(status).value,
    }


def point_cloud(
    xyz: np.ndarray,
    fitness: np.ndarray,
    stamp_ns: int,
    frame_id: str,
    age: np.ndarray | None = None,
    *,
    distinct: np.ndarray | None = None,
) -> fm.PointCloud:
    """Packed little-endian float32 fields x, y, z, fitness and, given, age (generations
    survived) and distinct (distinctness, NaN where not measured): 16 to 24 bytes a point."""
    xyz = np.asarray(xyz)
    fitness = np.asarray(fitness)
    if xyz.ndim != 2 or xyz.shape[1] != 3 or fitness.shape != (xyz.shape[0],):
        msg = f"point_cloud needs xyz (N, 3) and fitness (N,), got {xyz.shape} and {fitness.shape}"
        raise ValueError(msg)
    names: tuple[str, ...] = ("x", "y", "z", "fitness")
    columns = [xyz, fitness[:, None]]
    if age is not None:
        names += ("age",)
        columns.append(np.asarray(age).reshape(-1, 1))
    if distinct is not None:
        names += ("distinct",)
        columns.append(np.asarray(distinct).reshape(-1, 1))
    packed = np.empty((xyz.shape[0], len(names)), dtype="<f4")
    packed[:] = np.concatenate(columns, axis=1)
    return fm.PointCloud(
        timestamp=timestamp(stamp_ns),
        frame_id=frame_id,
        pose=_pose(0.0, 0.0, 0.0, (0.0, 0.0, 0.0, 1.0)),
        point_stride=4 * len(names),
        fields=[
            fm.PackedElementField(name=name, offset=4 * i, type=_F32)
            for i, name in enumerate(names)
        ],
        data=packed.tobytes(),
    )


class _Encoded:
    """A Foxglove message encoded here with numpy (messages of hundreds of points or poses,
    where building one SDK object each costs milliseconds). The writer takes it as it takes
    the SDK's messages: ``get_schema()`` on the class, ``encode()``."""

    __slots__ = ("_data",)

    def __init__(self, data: bytes) -> None:
        self._data = data

    def encode(self) -> bytes:
        return self._data


class EncodedImageAnnotations(_Encoded):
    """What :func:`image_annotations` returns: a foxglove.ImageAnnotations."""

    get_schema = staticmethod(fm.ImageAnnotations.get_schema)


class EncodedPosesInFrame(_Encoded):
    """What :func:`poses_in_frame` returns: a foxglove.PosesInFrame."""

    get_schema = staticmethod(fm.PosesInFrame.get_schema)


def image_annotations(
    uv: np.ndarray, colours: np.ndarray, stamp_ns: int, *, thickness: float = 3.0
) -> EncodedImageAnnotations:
    """One POINTS annotation: pixel positions (N, 2) with per-point RGBA colours (N, 4).

    Encoded here with numpy, byte for byte as the SDK's ``fm.ImageAnnotations(...).encode()``
    (tests/io/test_encode_bytes.py checks it): building one SDK object per point costs
    ~1.8 ms for a 1000-fly overlay, 5 times a second of log; this takes ~0.1 ms."""
    uv = np.asarray(uv, dtype=float)
    colours = np.asarray(colours, dtype=float)
    if uv.ndim != 2 or uv.shape[1] != 2 or colours.shape != (uv.shape[0], 4):
        msg = f"annotations need uv (N, 2) and colours (N, 4), got {uv.shape}, {colours.shape}"
        raise ValueError(msg)
    timestamp(stamp_ns)  # the SDK's range checks (seconds in uint32), same errors
    sec, nsec = _split_ns(stamp_ns)
    stamp = wire.varint_field(1, sec) + wire.varint_field(2, nsec)  # google.protobuf.Timestamp
    # PointsAnnotation fields, in field-number order as the SDK writes them: timestamp 1,
    # type 2, points 3 (Point2 x 1, y 2), outline_colors 5 (Color r 1, g 2, b 3, a 4),
    # thickness 7
    annotation = b"".join(
        (
            wire.bytes_field(1, stamp),
            wire.varint_field(2, fm.PointsAnnotationType.Points.value),
            wire.repeated_doubles(3, uv),
            wire.repeated_doubles(5, colours),
            wire.double_field(7, float(thickness)),
        )
    )
    # ImageAnnotations: points 2, timestamp 5
    return EncodedImageAnnotations(wire.bytes_field(2, annotation) + wire.bytes_field(5, stamp))


def grid(
    values: np.ndarray, origin: Pose2D, cell_size: float, stamp_ns: int, frame_id: str
) -> fm.Grid:
    """A float32 grid with one field "potential": ``values[row, col]``, columns along the
    grid's x axis, rows along its y axis, ``origin`` the pose of cell (0, 0)'s corner."""
    values = np.asarray(values)
    if values.ndim != 2:
        msg = f"grid values must be (rows, cols), got {values.shape}"
        raise ValueError(msg)
    cols = values.shape[1]
    data = np.ascontiguousarray(values, dtype="<f4")
    return fm.Grid(
        timestamp=timestamp(stamp_ns),
        frame_id=frame_id,
        pose=_planar_pose(origin),
        column_count=cols,
        cell_size=fm.Vector2(x=float(cell_size), y=float(cell_size)),
        row_stride=4 * cols,
        cell_stride=4,
        fields=[fm.PackedElementField(name="potential", offset=0, type=_F32)],
        data=data.tobytes(),
    )


def occupancy_grid(
    detected: np.ndarray,
    inflated: np.ndarray,
    origin: Pose2D,
    cell_size: float,
    stamp_ns: int,
    frame_id: str,
) -> fm.Grid:
    """A uint8 grid with one field "occupancy" (:data:`flylog.io.contract.PLANNER_MAP`): 100
    on the ``detected`` cells, 99 on the other ``inflated`` ones, 0 elsewhere; the layout of
    :func:`grid`."""
    detected, inflated = np.asarray(detected, bool), np.asarray(inflated, bool)
    if detected.ndim != 2 or detected.shape != inflated.shape:
        msg = f"occupancy needs two (rows, cols) masks, got {detected.shape}, {inflated.shape}"
        raise ValueError(msg)
    values = np.where(detected, 100, np.where(inflated, 99, 0)).astype(np.uint8)
    cols = values.shape[1]
    return fm.Grid(
        timestamp=timestamp(stamp_ns),
        frame_id=frame_id,
        pose=_planar_pose(origin),
        column_count=cols,
        cell_size=fm.Vector2(x=float(cell_size), y=float(cell_size)),
        row_stride=cols,
        cell_stride=1,
        fields=[
            fm.PackedElementField(
                name="occupancy", offset=0, type=fm.PackedElementFieldNumericType.Uint8
            )
        ],
        data=values.tobytes(),
    )


def poses_in_frame(poses: np.ndarray, stamp_ns: int, frame_id: str) -> EncodedPosesInFrame:
    """Planar poses (N, 3): x, y, theta.

    Encoded here with numpy, byte for byte as the SDK's ``fm.PosesInFrame(...).encode()``
    (tests/io/test_encode_bytes.py checks it): a planned path holds hundreds of poses at
    every snapshot, ~1 ms through SDK objects, on the planner's thread."""
    poses = np.asarray(poses, dtype=float)
    if poses.ndim != 2 or poses.shape[1] != 3:
        msg = f"poses must be (N, 3) x, y, theta, got {poses.shape}"
        raise ValueError(msg)
    timestamp(stamp_ns)  # the SDK's range checks (seconds in uint32), same errors
    sec, nsec = _split_ns(stamp_ns)
    half = poses[:, 2] / 2.0
    zeros = np.zeros(len(poses))
    position = np.column_stack([poses[:, 0], poses[:, 1], zeros])
    orientation = np.column_stack([zeros, zeros, np.sin(half), np.cos(half)])
    # PosesInFrame: timestamp 1, frame_id 2, poses 3 (Pose: position 1, orientation 2)
    return EncodedPosesInFrame(
        wire.bytes_field(1, wire.varint_field(1, sec) + wire.varint_field(2, nsec))
        + (wire.bytes_field(2, frame_id.encode()) if frame_id else b"")
        + wire.repeated_poses(3, position, orientation)
    )


def scene_update(
    shapes: Iterable[BoxShape | CylinderShape], stamp_ns: int, frame_id: str
) -> fm.SceneUpdate:
    """One entity per shape (its id the shape's id), lasting forever."""
    ts = timestamp(stamp_ns)
    entities = []
    for shape in shapes:
        x, y, z = shape.centre
        if isinstance(shape, BoxShape):
            cubes = [
                fm.CubePrimitive(
                    pose=_pose(x, y, z, yaw_quaternion(shape.yaw)),
                    size=fm.Vector3(x=shape.size[0], y=shape.size[1], z=shape.size[2]),
                    color=_colour(shape.colour),
                )
            ]
            cylinders = []
        elif isinstance(shape, CylinderShape):
            cubes = []
            cylinders = [
                fm.CylinderPrimitive(
                    pose=_pose(x, y, z, (0.0, 0.0, 0.0, 1.0)),
                    size=fm.Vector3(x=shape.diameter, y=shape.diameter, z=shape.height),
                    bottom_scale=1.0,
                    top_scale=1.0,
                    color=_colour(shape.colour),
                )
            ]
        else:
            msg = f"scene shapes must be BoxShape or CylinderShape, got {type(shape).__name__}"
            raise TypeError(msg)
        entities.append(
            fm.SceneEntity(
                timestamp=ts,
                frame_id=frame_id,
                id=shape.id,
                lifetime=fm.Duration(0, 0),
                cubes=cubes,
                cylinders=cylinders,
            )
        )
    return fm.SceneUpdate(entities=entities)
