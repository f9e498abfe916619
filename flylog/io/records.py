"""Plain records that the encoders take and the decoders return (no MCAP, no protobuf)."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from flylog.geometry import Pose2D

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]  # x, y, z, w
Rgba = tuple[float, float, float, float]  # each in [0, 1]


class Transform(NamedTuple):
    """The pose of frame ``child`` in frame ``parent`` (a point in child maps to parent)."""

    parent: str
    child: str
    translation: Vec3
    rotation: Quat


class BoxShape(NamedTuple):
    """A box standing in the scene: centre (m), size along its own x, y, z (m), yaw (rad)."""

    id: str
    centre: Vec3
    size: Vec3
    yaw: float
    colour: Rgba


class CylinderShape(NamedTuple):
    """An upright cylinder: centre (m), diameter and height (m)."""

    id: str
    centre: Vec3
    diameter: float
    height: float
    colour: Rgba


class Calibration(NamedTuple):
    """A decoded CameraCalibration: image size, K (3, 3) and P (3, 4)."""

    width: int
    height: int
    K: np.ndarray
    P: np.ndarray


class FlyCloud(NamedTuple):
    """A decoded PointCloud: xyz (N, 3), fitness (N,) and, if the cloud has them, age (N,)
    and distinct (N,: distinctness, NaN where not measured)."""

    xyz: np.ndarray
    fitness: np.ndarray
    age: np.ndarray | None = None
    distinct: np.ndarray | None = None


class Overlay(NamedTuple):
    """Decoded image annotations: pixel positions (N, 2) and RGBA colours (N, 4)."""

    uv: np.ndarray
    colours: np.ndarray


class GridValues(NamedTuple):
    """A decoded Grid: values (rows, cols), the pose of cell (0, 0)'s corner, cell size (m).

    Row i, column j covers ``origin ⊕ (j·cell .. (j+1)·cell, i·cell .. (i+1)·cell)``:
    columns run along the grid's x axis, rows along its y axis (Foxglove's layout)."""

    values: np.ndarray
    origin: Pose2D
    cell: float


class LogMessage(NamedTuple):
    """One message of a log, decoded into plain values (see ``flylog.io.decode``)."""

    topic: str
    log_time_ns: int
    schema: str
    value: Any


class TopicInfo(NamedTuple):
    schema: str
    count: int  # type: ignore[assignment]  # shadows tuple.count, which nothing calls


class LogAttachment(NamedTuple):
    name: str
    media_type: str
    log_time_ns: int
    data: bytes
