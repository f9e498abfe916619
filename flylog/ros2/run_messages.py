"""Standard ROS 2 messages of a run's outputs (fly clouds, grids, paths, commands, depth
images), built from plain values as ``rosbags`` objects of the standard typestore."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from rosbags.typesys.store import Typestore

from flylog.geometry import Pose2D
from flylog.ros2.messages import Builder

POINT_CLOUD2 = "sensor_msgs/msg/PointCloud2"
OCCUPANCY_GRID = "nav_msgs/msg/OccupancyGrid"
PATH = "nav_msgs/msg/Path"
TWIST_STAMPED = "geometry_msgs/msg/TwistStamped"
STRING = "std_msgs/msg/String"
FLOAT_IMAGE = "32FC1"  # sensor_msgs/image_encodings: one float32 channel


class RunBuilder(Builder):
    """Makes the run's messages (and, inherited, the sensor ones)."""

    def __init__(self, store: Typestore) -> None:
        super().__init__(store)
        self._float32 = 7  # sensor_msgs/msg/PointField.FLOAT32

    def point_cloud(
        self, stamp_ns: int, frame_id: str, columns: Sequence[tuple[str, np.ndarray]]
    ) -> Any:
        """An unorganised PointCloud2 (height 1) of little-endian float32 fields, one per
        ``(name, values (N,))`` column, in that order (x, y, z first)."""
        n = len(columns[0][1]) if columns else 0
        packed = np.empty((n, len(columns)), dtype="<f4")
        for i, (_, values) in enumerate(columns):
            packed[:, i] = values
        t = self._t
        fields = [
            t["sensor_msgs/msg/PointField"](
                name=name, offset=4 * i, datatype=self._float32, count=1
            )
            for i, (name, _) in enumerate(columns)
        ]
        step = 4 * len(columns)
        return t[POINT_CLOUD2](
            header=self.header(stamp_ns, frame_id),
            height=1,
            width=n,
            fields=fields,
            is_bigendian=False,
            point_step=step,
            row_step=step * n,
            data=packed.reshape(-1).view(np.uint8),
            is_dense=bool(np.isfinite(packed).all()),
        )

    def _pose(self, x: float, y: float, theta: float) -> Any:
        t = self._t
        point = t["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0)
        half = 0.5 * float(theta)
        rotation = self._quaternion((0.0, 0.0, np.sin(half), np.cos(half)))
        return t["geometry_msgs/msg/Pose"](position=point, orientation=rotation)

    def occupancy_grid(
        self, stamp_ns: int, frame_id: str, cells: np.ndarray, origin: Pose2D, cell_size: float
    ) -> Any:
        """An OccupancyGrid of ``cells`` (rows, cols) int8 in -1..100, row 0 at ``origin``
        (the pose of cell (0, 0)'s corner), rows along its y axis, columns along its x."""
        t = self._t
        rows, cols = cells.shape
        sec, nsec = divmod(int(stamp_ns), 1_000_000_000)
        info = t["nav_msgs/msg/MapMetaData"](
            map_load_time=t["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec),
            resolution=float(cell_size),
            width=cols,
            height=rows,
            origin=self._pose(origin.x, origin.y, origin.theta),
        )
        data = np.ascontiguousarray(cells, dtype=np.int8).reshape(-1)
        return t[OCCUPANCY_GRID](header=self.header(stamp_ns, frame_id), info=info, data=data)

    def path(self, stamp_ns: int, frame_id: str, poses: np.ndarray) -> Any:
        """A Path of planar poses (K, 3): x, y, theta, each stamped as the path (one header
        object shared by all: a path holds hundreds of poses at every snapshot)."""
        t = self._t
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        header = self.header(stamp_ns, frame_id)
        point, quaternion = t["geometry_msgs/msg/Point"], t["geometry_msgs/msg/Quaternion"]
        pose, stamped = t["geometry_msgs/msg/Pose"], t["geometry_msgs/msg/PoseStamped"]
        half = 0.5 * poses[:, 2]
        rows = zip(
            poses[:, 0].tolist(),
            poses[:, 1].tolist(),
            np.sin(half).tolist(),
            np.cos(half).tolist(),
            strict=True,
        )
        return t[PATH](
            header=header,
            poses=[
                stamped(
                    header=header,
                    pose=pose(
                        position=point(x=x, y=y, z=0.0),
                        orientation=quaternion(x=0.0, y=0.0, z=qz, w=qw),
                    ),
                )
                for x, y, qz, qw in rows
            ],
        )

    def twist(self, stamp_ns: int, frame_id: str, linear: float, angular: float) -> Any:
        """A TwistStamped: ``linear`` along x (m/s), ``angular`` about z (rad/s)."""
        t = self._t
        twist = t["geometry_msgs/msg/Twist"](
            linear=self._vector(linear, 0.0, 0.0), angular=self._vector(0.0, 0.0, angular)
        )
        return t[TWIST_STAMPED](header=self.header(stamp_ns, frame_id), twist=twist)

    def text(self, value: str) -> Any:
        return self._t[STRING](data=value)

    def float_image(self, stamp_ns: int, frame_id: str, values: np.ndarray) -> Any:
        """A 32FC1 Image (little endian) of ``values`` (H, W)."""
        pixels = np.ascontiguousarray(values, dtype="<f4")
        h, w = pixels.shape
        return self._t["sensor_msgs/msg/Image"](
            header=self.header(stamp_ns, frame_id),
            height=h,
            width=w,
            encoding=FLOAT_IMAGE,
            is_bigendian=0,
            step=4 * w,
            data=pixels.reshape(-1).view(np.uint8),
        )
