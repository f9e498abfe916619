"""Decoders: from a decoded protobuf message (built by mcap_protobuf from the schema the
log carries, so any valid Foxglove log works) or a JSON dict, to plain values.

Arrays over a message's bytes are read-only zero-copy views where the layout allows.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable
from types import MappingProxyType
from typing import Any, NamedTuple

import numpy as np
from google.protobuf import descriptor_pb2

from flylog.errors import LogError
from flylog.geometry import Pose2D
from flylog.io import contract
from flylog.io.records import (
    BoxShape,
    Calibration,
    CylinderShape,
    FlyCloud,
    GridValues,
    Overlay,
    Transform,
)
from flylog.sensors import OdomReading, SonarReading

_CHANNELS = MappingProxyType({"rgb8": 3, "bgr8": 3, "mono8": 1})
FLOAT_IMAGE = "32FC1"  # one float32 channel: /truth/disparity
# PackedElementField numeric types → numpy little-endian dtypes (0 = unknown).
_NUMERIC = MappingProxyType(
    {1: "u1", 2: "i1", 3: "<u2", 4: "<i2", 5: "<u4", 6: "<i4", 7: "<f4", 8: "<f8"}
)


def stamp_ns(ts: Any) -> int:
    """Integer nanoseconds of a protobuf Timestamp or a JSON ``{"sec", "nsec"}``."""
    if isinstance(ts, dict):
        return int(ts["sec"]) * 1_000_000_000 + int(ts["nsec"])
    return int(ts.seconds) * 1_000_000_000 + int(ts.nanos)


def yaw_of(q: Any) -> float:
    """Heading (rad) of a quaternion message: the rotation about z of its x axis."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def _planar(pose: Any) -> Pose2D:
    return Pose2D(pose.position.x, pose.position.y, yaw_of(pose.orientation))


def image(msg: Any) -> np.ndarray:
    """RawImage → (H, W, 3) RGB or (H, W) uint8, a read-only view of the message bytes
    ("bgr8" comes back as RGB through a reversed view); "32FC1" (ground-truth disparity,
    little endian) → (H, W) float32."""
    if msg.encoding == FLOAT_IMAGE:
        h, w, step = msg.height, msg.width, msg.step
        if step < 4 * w or len(msg.data) < step * (h - 1) + 4 * w:
            msg_ = f"image of {w}×{h} 32FC1 has step {step} and only {len(msg.data)} bytes"
            raise LogError(msg_)
        return np.ndarray((h, w), dtype="<f4", buffer=msg.data, strides=(step, 4))
    channels = _CHANNELS.get(msg.encoding)
    if channels is None:
        msg_ = f"image encoding '{msg.encoding}' is not supported (rgb8, bgr8, mono8 are)"
        raise LogError(msg_)
    h, w, step = msg.height, msg.width, msg.step
    data = msg.data
    if step < w * channels or len(data) < step * (h - 1) + w * channels:
        msg_ = f"image of {w}×{h} {msg.encoding} has step {step} and only {len(data)} bytes"
        raise LogError(msg_)
    if channels == 1:
        return np.ndarray((h, w), dtype=np.uint8, buffer=data, strides=(step, 1))
    view = np.ndarray((h, w, 3), dtype=np.uint8, buffer=data, strides=(step, 3, 1))
    return view[..., ::-1] if msg.encoding == "bgr8" else view


class RawImageFields(NamedTuple):
    """What :func:`image` reads of a foxglove.RawImage, as :func:`raw_image_fields` parses
    it (``data`` a view of the message bytes, not a copy)."""

    width: int
    height: int
    encoding: str
    step: int
    data: memoryview


# foxglove.RawImage as Foxglove's schema numbers it: (name, field number, descriptor type)
_FOXGLOVE_RAW_IMAGE = frozenset(
    {
        ("timestamp", 1, descriptor_pb2.FieldDescriptorProto.TYPE_MESSAGE),
        ("frame_id", 7, descriptor_pb2.FieldDescriptorProto.TYPE_STRING),
        ("width", 2, descriptor_pb2.FieldDescriptorProto.TYPE_FIXED32),
        ("height", 3, descriptor_pb2.FieldDescriptorProto.TYPE_FIXED32),
        ("encoding", 4, descriptor_pb2.FieldDescriptorProto.TYPE_STRING),
        ("step", 5, descriptor_pb2.FieldDescriptorProto.TYPE_FIXED32),
        ("data", 6, descriptor_pb2.FieldDescriptorProto.TYPE_BYTES),
    }
)
_FIXED32 = struct.Struct("<I")
_RAW_IMAGE_FIXED32 = MappingProxyType({2: "width", 3: "height", 5: "step"})


def is_foxglove_raw_image(schema_data: bytes) -> bool:
    """Whether a protobuf schema (a FileDescriptorSet) defines foxglove.RawImage with
    Foxglove's fields, which :func:`raw_image_fields` parses."""
    try:
        files = descriptor_pb2.FileDescriptorSet.FromString(schema_data).file
    except Exception:  # not a descriptor set: leave it to the generic decoder
        return False
    for f in files:
        for m in f.message_type:
            if f.package == "foxglove" and m.name == "RawImage":
                return {(x.name, x.number, x.type) for x in m.field} == _FOXGLOVE_RAW_IMAGE
    return False


def _varint(view: memoryview, at: int) -> tuple[int, int]:
    value, shift = 0, 0
    while True:
        if at >= len(view) or shift > 63:
            msg = "image message cut inside a varint"
            raise LogError(msg)
        byte = view[at]
        at += 1
        value |= (byte & 0x7F) << shift
        if byte < 0x80:
            return value, at
        shift += 7


def raw_image_fields(data: bytes | memoryview) -> RawImageFields:
    """A foxglove.RawImage's serialised bytes (Foxglove's field numbers,
    :func:`is_foxglove_raw_image`) → the fields :func:`image` reads, its pixels a view of
    ``data``: protobuf's parser copies them, ~1 MB a 640×480 image, holding the GIL. Other
    fields are skipped; a repeated field keeps its last value, as protobuf does."""
    view = memoryview(data)
    fields: dict[str, Any] = {"width": 0, "height": 0, "step": 0, "encoding": ""}
    pixels = view[:0]
    at, end = 0, len(view)
    while at < end:
        key, at = _varint(view, at)
        number, wire = key >> 3, key & 7
        if wire == 0:
            _, at = _varint(view, at)
        elif wire == 5:
            if at + 4 > end:
                break
            if number in _RAW_IMAGE_FIXED32:
                fields[_RAW_IMAGE_FIXED32[number]] = _FIXED32.unpack_from(view, at)[0]
            at += 4
        elif wire == 1:
            at += 8
        elif wire == 2:
            length, at = _varint(view, at)
            if at + length > end:
                break
            if number == 4:
                fields["encoding"] = str(view[at : at + length], "utf-8")
            elif number == 6:
                pixels = view[at : at + length]
            at += length
        else:
            msg = f"image message has a field of wire type {wire}"
            raise LogError(msg)
    if at != end:
        msg = "image message is cut short"
        raise LogError(msg)
    return RawImageFields(data=pixels, **fields)


def calibration(msg: Any) -> Calibration:
    return Calibration(
        msg.width,
        msg.height,
        np.array(msg.K, dtype=float).reshape(3, 3),
        np.array(msg.P, dtype=float).reshape(3, 4),
    )


def pose_reading(msg: Any) -> OdomReading:
    return OdomReading(stamp_ns(msg.timestamp), _planar(msg.pose))


def transforms(msg: Any) -> list[Transform]:
    return [
        Transform(
            t.parent_frame_id,
            t.child_frame_id,
            (t.translation.x, t.translation.y, t.translation.z),
            (t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w),
        )
        for t in msg.transforms
    ]


def _field_view(data: bytes, count: int, stride: int, field: Any) -> np.ndarray:
    dtype = _NUMERIC.get(int(field.type))
    if dtype is None:
        msg = f"packed field '{field.name}' has an unknown numeric type {field.type}"
        raise LogError(msg)
    return np.ndarray((count,), dtype=dtype, buffer=data, offset=field.offset, strides=(stride,))


def fly_cloud(msg: Any) -> FlyCloud:
    """PointCloud → xyz (N, 3), fitness (N,) (NaN if the cloud has none), age and distinct."""
    fields = {f.name: f for f in msg.fields}
    missing = [n for n in ("x", "y", "z") if n not in fields]
    if missing or msg.point_stride <= 0:
        msg_ = f"point cloud lacks fields {missing} or has stride {msg.point_stride}"
        raise LogError(msg_)
    stride, data = msg.point_stride, msg.data
    count = len(data) // stride
    if count == 0:  # numpy refuses a view with an offset into an empty buffer
        return FlyCloud(np.empty((0, 3), np.float32), np.empty(0, np.float32))
    fx, fy, fz = fields["x"], fields["y"], fields["z"]
    f32 = 7
    if (fx.type, fy.type, fz.type) == (f32, f32, f32) and (fy.offset, fz.offset) == (
        fx.offset + 4,
        fx.offset + 8,
    ):
        xyz = np.ndarray(
            (count, 3), dtype="<f4", buffer=data, offset=fx.offset, strides=(stride, 4)
        )
    else:
        xyz = np.stack([_field_view(data, count, stride, f) for f in (fx, fy, fz)], axis=1)
        xyz = xyz.astype(np.float32)
    if "fitness" in fields:
        fitness = _field_view(data, count, stride, fields["fitness"])
    else:
        fitness = np.full(count, np.nan, dtype=np.float32)
    age, distinct = (
        _field_view(data, count, stride, fields[name]) if name in fields else None
        for name in ("age", "distinct")
    )
    return FlyCloud(xyz, fitness, age, distinct)


def overlay(msg: Any) -> Overlay:
    """ImageAnnotations → every points annotation's points and per-point colours."""
    uv = [(p.x, p.y) for ann in msg.points for p in ann.points]
    colours = []
    for ann in msg.points:
        per_point = [(c.r, c.g, c.b, c.a) for c in ann.outline_colors]
        if len(per_point) != len(ann.points):
            c = ann.outline_color
            per_point = [(c.r, c.g, c.b, c.a)] * len(ann.points)
        colours.extend(per_point)
    return Overlay(np.array(uv, dtype=float).reshape(-1, 2), np.array(colours).reshape(-1, 4))


def grid_values(msg: Any) -> GridValues:
    """Grid → its first field ("potential" if present) as (rows, cols)."""
    if not msg.fields or msg.column_count <= 0 or msg.row_stride <= 0:
        msg_ = "grid has no fields or no columns"
        raise LogError(msg_)
    fields = {f.name: f for f in msg.fields}
    field = fields.get("potential", msg.fields[0])
    dtype = _NUMERIC.get(int(field.type))
    if dtype is None:
        msg_ = f"grid field '{field.name}' has an unknown numeric type {field.type}"
        raise LogError(msg_)
    rows = len(msg.data) // msg.row_stride
    values = np.ndarray(
        (rows, msg.column_count),
        dtype=dtype,
        buffer=msg.data,
        offset=field.offset,
        strides=(msg.row_stride, msg.cell_stride),
    )
    return GridValues(values, _planar(msg.pose), float(msg.cell_size.x))


def planar_poses(msg: Any) -> np.ndarray:
    """PosesInFrame → (N, 3): x, y, theta."""
    out = np.array(
        [(p.position.x, p.position.y, yaw_of(p.orientation)) for p in msg.poses], dtype=float
    )
    return out.reshape(-1, 3)


def shapes(msg: Any) -> list[BoxShape | CylinderShape]:
    """SceneUpdate → its cubes and cylinders as flylog shapes (ids from the entities)."""
    out: list[BoxShape | CylinderShape] = []
    for entity in msg.entities:
        for cube in entity.cubes:
            p, s, c = cube.pose.position, cube.size, cube.color
            out.append(
                BoxShape(
                    entity.id,
                    (p.x, p.y, p.z),
                    (s.x, s.y, s.z),
                    yaw_of(cube.pose.orientation),
                    (c.r, c.g, c.b, c.a),
                )
            )
        for cyl in entity.cylinders:
            p, s, c = cyl.pose.position, cyl.size, cyl.color
            out.append(CylinderShape(entity.id, (p.x, p.y, p.z), s.x, s.z, (c.r, c.g, c.b, c.a)))
    return out


def sonar_reading(data: dict[str, Any]) -> SonarReading:
    ranges = np.array([np.nan if r is None else r for r in data["ranges"]], dtype=float)
    return SonarReading(
        stamp_ns=stamp_ns(data["timestamp"]),
        ranges=ranges,
        mounts=np.array(data["mounts"], dtype=float).reshape(-1, 3),
        cone_angle=float(data["cone_angle"]),
        max_range=float(data["max_range"]),
    )


def command(data: dict[str, Any]) -> dict[str, Any]:
    """``flylog.Command`` → {"stamp_ns", "linear", "angular", "status"}."""
    return {
        "stamp_ns": stamp_ns(data["timestamp"]),
        "linear": float(data["linear"]),
        "angular": float(data["angular"]),
        "status": data["status"],
    }


DECODERS: MappingProxyType[str, Callable[[Any], Any]] = MappingProxyType(
    {
        contract.RAW_IMAGE: image,
        contract.CAMERA_CALIBRATION: calibration,
        contract.POSE_IN_FRAME: pose_reading,
        contract.FRAME_TRANSFORMS: transforms,
        contract.POINT_CLOUD: fly_cloud,
        contract.IMAGE_ANNOTATIONS: overlay,
        contract.GRID: grid_values,
        contract.POSES_IN_FRAME: planar_poses,
        contract.SCENE_UPDATE: shapes,
        contract.SONAR_RANGES: sonar_reading,
        contract.COMMAND: command,
    }
)
