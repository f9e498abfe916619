"""ROS 2 bags in and out: reading a bag (a ``ros2``-profile MCAP file or a rosbag2
directory) into flylog's sensor records for replay (:mod:`flylog.ros2.source`), and writing
a flylog log as a rosbag2 directory of standard messages (:mod:`flylog.ros2.export`)."""

from flylog.ros2.detect import is_bag

__all__ = ["is_bag"]
