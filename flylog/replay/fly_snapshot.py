"""A snapshot of the flies, run as a job of :class:`~flylog.replay.worker.OutputQueue`: the
published population as a point cloud in base_link at the robot's pose (with each fly's
distinctness when the obstacle rule reads it), its overlay on the left image and
odom → base_link there, encoded as the log's messages.

The job reads only what it is given, captured at its virtual time, and the obstacle rule's
answers (:class:`~flylog.replay.obstacle_cache.Evidence`, shared with the planner's ticks on
the same thread): it may run on a worker thread while the engine goes on."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from flylog.geometry import Pose2D, StereoRig, relative
from flylog.geometry.proprioception import moved_by_odometry
from flylog.io import contract, encode
from flylog.replay.obstacle_cache import Evidence
from flylog.replay.overlay import fly_overlay
from flylog.replay.publication import Published


@dataclass(frozen=True)
class SnapshotInputs:
    """What a snapshot at ``t_ns`` writes, captured at that virtual time."""

    t_ns: int
    published: Published
    robot_pose: Pose2D  # where the robot is at t_ns (the odometry carried on to it)


class FlySnapshots:
    """The flies' messages of each snapshot; ``write_tf`` adds odom → base_link, and
    ``overlay_flies`` bounds the flies drawn on the overlay."""

    def __init__(
        self, rig: StereoRig, evidence: Evidence, *, overlay_flies: int, write_tf: bool
    ) -> None:
        self.rig = rig
        self._evidence = evidence
        self._overlay_flies = overlay_flies
        self._write_tf = write_tf

    def snapshot(self, snap: SnapshotInputs) -> list[tuple[str, int, Any]]:
        """The flies in base_link at the robot's pose, their overlay and odom → base_link
        there; nothing before a population is published."""
        t_ns, seen, robot_pose = snap.t_ns, snap.published, snap.robot_pose
        pop = seen.population
        if pop is None:
            return []
        distinct = None
        if seen.candidates is not None:
            distinct = self._evidence.of(pop, seen.pair, seen.generation, seen.candidates)[1]
        # on the images the flies were scored on
        uv, colours = fly_overlay(pop, self.rig, self._overlay_flies)
        # The flies are expressed where the robot was when their images were taken; the
        # cloud goes out in base_link at the snapshot's time, like every message (the
        # metrics render the truth there).
        xyz = pop.xyz
        if seen.pose != robot_pose:
            xyz = moved_by_odometry(xyz, relative(seen.pose, robot_pose))
        cloud = encode.point_cloud(
            xyz, pop.fitness, t_ns, contract.BASE_FRAME, pop.age, distinct=distinct
        )
        messages: list[tuple[str, int, Any]] = [
            (contract.FLIES, t_ns, cloud),
            (contract.FLIES_OVERLAY, t_ns, encode.image_annotations(uv, colours, t_ns)),
        ]
        if self._write_tf:
            transform = encode.odom_transform(robot_pose)
            messages.append((contract.TF, t_ns, encode.frame_transforms([transform], t_ns)))
        return messages
