"""flylog.export: a run's outputs in another format, for other tools. ``run_bag``: a run as
a rosbag2 directory (``flylog export RUN --ros2 OUT``); it stands above metrics and sources
because the bag carries the run's obstacle rule and the rig of the log replayed, and writes
through :mod:`flylog.ros2`'s bag writer and messages."""
