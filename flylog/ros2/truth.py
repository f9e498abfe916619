"""Trajectories and ground truth of a bag, for ``flylog export --tum`` and ``flylog metrics
--log``: the odometry (the one Odometry topic outside ``/truth/``, else ``/tf`` odom →
base_link, directly or through a frame ``/tf_static`` connects to it), the true pose
(``/truth/odom``) and, for metrics, the scene that the exporter of a simulated log stores
in custom_data."""

from __future__ import annotations

import os
import warnings
from pathlib import Path

from flylog.errors import LogError
from flylog.io.contract import TRUTH_PREFIX
from flylog.metrics.trajectory import Trajectory, trajectory
from flylog.metrics.truth import LogTruth
from flylog.ros2 import types
from flylog.ros2.bag import Bag, open_bag, static_tree
from flylog.ros2.odometry import OdometryReader

TRUTH_ODOM = "/truth/odom"


def _poses(bag: Bag, topic: str, *, from_tf: bool) -> Trajectory:
    """A topic's planar poses at their log times."""
    tree = static_tree(bag) if from_tf else None
    reader = OdometryReader(str(bag.path), from_tf=from_tf, tree=tree)
    times, poses = [], []
    for m in bag.messages([topic]):
        for r in reader.readings(m.value):
            times.append(m.log_time_ns)
            poses.append((r.pose.x, r.pose.y, r.pose.theta))
    return trajectory(times, poses)


def bag_trajectories(path: str | os.PathLike[str]) -> dict[str, Trajectory]:
    """name (true, odom) → trajectory, for those the bag holds."""
    bag = open_bag(path)
    topics = bag.topics()
    out: dict[str, Trajectory] = {}
    if topics.get(TRUTH_ODOM) is not None and topics[TRUTH_ODOM].schema == types.ODOMETRY:
        out["true"] = _poses(bag, TRUTH_ODOM, from_tf=False)
    odometry = [
        t
        for t, i in topics.items()
        if i.schema == types.ODOMETRY and not t.startswith(TRUTH_PREFIX)
    ]
    if len(odometry) == 1:
        out["odom"] = _poses(bag, odometry[0], from_tf=False)
    elif not odometry and types.TF in topics:
        odom = _poses(bag, types.TF, from_tf=True)
        if len(odom):
            out["odom"] = odom
    return out


def bag_truth(path: str | os.PathLike[str]) -> LogTruth:
    """The ground truth of a bag exported from a simulated log (``flylog export --ros2
    --truth``): LogError naming what is missing otherwise."""
    from flylog.ros2.config import BagOptions
    from flylog.ros2.source import SCENE_KEY, BagSource
    from flylog.scene.load import parse_scene

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # replay's warnings (no goal, no odometry)
        source = BagSource(Path(path), BagOptions())
    bag = source.bag
    missing = [
        what
        for what, there in (
            (f"{TRUTH_ODOM} (the true pose)", TRUTH_ODOM in bag.topics()),
            (f"custom_data {SCENE_KEY} (the scene)", SCENE_KEY in bag.custom),
            ("an odometry topic", source.roles.odom is not None),
        )
        if not there
    ]
    if missing:
        msg = (
            f"{path} carries no ground truth for metrics: it lacks {', '.join(missing)} "
            f"(`flylog export LOG --ros2 OUT --truth` writes them)"
        )
        raise LogError(msg)
    found = bag_trajectories(path)
    for name, what in (("true", f"{TRUTH_ODOM} (the true pose)"), ("odom", "the odometry")):
        if name not in found:
            msg = f"{path}: {what} gives no pose that can be read; metrics needs it"
            raise LogError(msg)
    scene = parse_scene(bag.custom[SCENE_KEY], f"{path}: custom_data {SCENE_KEY}")
    return LogTruth(
        path=Path(path), scene=scene, rig=source.rig, true=found["true"], odom=found["odom"]
    )
