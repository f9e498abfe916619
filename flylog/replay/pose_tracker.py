"""The robot's pose as the pipeline knows it: the odometry, interpolated to each image's
stamp and heading-corrected by the flies' visual measurement of each turn
(``config.heading``: :class:`flylog.fly.heading.VisualHeading`, an engine feature)."""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from flylog.fly.config import Similarity
from flylog.fly.heading import KEYFRAME_FLIES as KEYFRAME_FLIES
from flylog.fly.heading import HeadingConfig, VisualHeading
from flylog.fly.population import Population
from flylog.geometry import Pose2D, StereoRig, compose, inverse, relative
from flylog.geometry.poses import wrap_angle
from flylog.sensors import OdomReading, StereoPair

# Odometry readings kept to find the pose at an image's stamp: 16 at 50 Hz span 0.3 s, more
# than --sync's delay of one frame period.
ODOM_HISTORY = 16


def pose_at(readings: deque[OdomReading], stamp_ns: int) -> Pose2D:
    """The odometric pose at ``stamp_ns``: linear between the two readings around it (the
    heading along the shorter way); past the newest reading, the newest two's motion carried
    on for at most one interval between them (records come in stamp order: an image is
    delivered before the reading after it, up to an odometry period later, 10 mrad of turn
    at 0.5 rad/s); before the oldest kept, the oldest.

    Scalar, over a short deque, rather than :class:`flylog.metrics.trajectory.PoseInterpolator`:
    that one clamps past the newest reading instead of carrying the motion on, and its
    ``np.interp`` rounds differently (1184 of 4000 random stamps between readings differ in
    the last bits), which would change replay's output."""
    newest = readings[-1]
    if stamp_ns >= newest.stamp_ns:
        if len(readings) < 2 or stamp_ns == newest.stamp_ns:
            return newest.pose
        previous = readings[-2]
        span = newest.stamp_ns - previous.stamp_ns
        if span <= 0:
            return newest.pose
        return _along(
            previous.pose, newest.pose, 1.0 + min(stamp_ns - newest.stamp_ns, span) / span
        )
    later = newest
    for earlier in reversed(readings):
        if earlier.stamp_ns <= stamp_ns:
            if later.stamp_ns == earlier.stamp_ns:
                return earlier.pose
            a = (stamp_ns - earlier.stamp_ns) / (later.stamp_ns - earlier.stamp_ns)
            return _along(earlier.pose, later.pose, a)
        later = earlier
    return later.pose


def _along(p: Pose2D, q: Pose2D, a: float) -> Pose2D:
    """The pose a fraction ``a`` of the way from p to q (a > 1: beyond q), position and
    heading (the shorter way) linear."""
    turn = wrap_angle(q.theta - p.theta)
    return Pose2D(p.x + a * (q.x - p.x), p.y + a * (q.y - p.y), wrap_angle(p.theta + a * turn))


@dataclass(frozen=True)
class PairPose:
    """Where the robot was when a stereo pair was taken, as :meth:`PoseTracker.at_pair`
    finds it: the motion since the previous pair (None for the first), and the fitness
    evaluations a heading measurement made on the way (0: none)."""

    motion: Pose2D | None
    evaluations: int


class PoseTracker:
    """The newest odometry (:attr:`odom`) and the pose at the newest stereo pair
    (:attr:`at_images`), both heading-corrected: the robot's pose is the visual heading's
    correction ⊕ the odometry's (no correction until the first measurement)."""

    def __init__(
        self,
        config: HeadingConfig,
        rig: StereoRig,
        start: Pose2D,
        similarity: Similarity = Similarity.ZSSD,
    ) -> None:
        self._heading = VisualHeading(config, rig, similarity)
        self._odom = OdomReading(0, start)
        self._history: deque[OdomReading] = deque([self._odom], maxlen=ODOM_HISTORY)
        self._correction: Pose2D | None = None
        self._pair: StereoPair | None = None  # the newest pair
        # (corrected) odometry at the newest pair's stamp: the engine's flies are expressed
        # in base_link there
        self.at_images: Pose2D | None = None

    @property
    def odom(self) -> OdomReading:
        """The newest odometry reading, heading-corrected."""
        return self._odom

    def at(self, stamp_ns: int) -> Pose2D:
        """The robot's pose at ``stamp_ns``, heading-corrected (:func:`pose_at`: past the
        newest reading, its motion carried on): where a message stamped then is in base_link.
        """
        return self._corrected(pose_at(self._history, stamp_ns))

    def readout(self, stamp_ns: int, span_ns: int) -> Pose2D:
        """The robot's motion over an image's readout, ``span_ns`` long from ``stamp_ns``
        (a rolling shutter's, :mod:`flylog.geometry.rolling`), from the odometry kept: the
        motion from :meth:`at` ``stamp_ns`` to :meth:`at` ``stamp_ns + span_ns``, in base_link
        at the stamp (the heading's correction, the same at both ends, cancels). Where the
        readout's end lies past the newest reading (a pair is delivered before the readings
        after its stamp; 31.2 ms of readout at 240 rows of 130 µs is longer than a 50 Hz
        reading interval, over which :func:`pose_at` carries the motion on at most), the
        same span ending at the newest reading (or at the stamp, if that is later): the
        motion at the same constant velocity, measured instead of carried on."""
        if span_ns <= 0:
            return Pose2D()
        end = min(stamp_ns + span_ns, max(self._history[-1].stamp_ns, stamp_ns))
        return relative(self.at(end - span_ns), self.at(end))

    def add_odometry(self, reading: OdomReading) -> None:
        self._history.append(reading)
        self._odom = OdomReading(reading.stamp_ns, self._corrected(reading.pose))

    def at_pair(self, pair: StereoPair, population: Callable[[], Population]) -> PairPose:
        """Move to the stereo ``pair``: the pose at its stamp becomes :attr:`at_images`.

        The flies are scored on the pair's images, so they are moved by the odometry between
        the two pairs' stamps, to where the robot was when those were taken; the newest
        odometry would put them up to a frame period (and, --sync, two) off their images'
        pose: 20-30 mrad of rotation at 0.5 rad/s, in the published cloud too.
        ``population()`` gives the flies a new keyframe keeps (read only when one starts).
        """
        odometry = pose_at(self._history, pair.stamp_ns)
        pose = self._corrected(odometry)
        motion, evaluations = None, 0
        if self.at_images is not None:
            pose, evaluations = self._heading_measured(pair, odometry, pose, population)
            motion = relative(self.at_images, pose)
        self.at_images = pose
        self._pair = pair
        return PairPose(motion, evaluations)

    def _corrected(self, odometry: Pose2D) -> Pose2D:
        """The robot's pose for an odometric pose: the heading's correction ⊕ it."""
        return odometry if self._correction is None else compose(self._correction, odometry)

    def _heading_measured(
        self,
        pair: StereoPair,
        odometry: Pose2D,
        pose: Pose2D,
        population: Callable[[], Population],
    ) -> tuple[Pose2D, int]:
        """The robot's pose at ``pair`` (``pose``, from ``odometry`` there), its heading
        corrected when the engine's visual heading (:class:`~flylog.fly.heading.VisualHeading`)
        measures the turn since its keyframe; the correction then applies to all odometry.
        Also the measurement's fitness evaluations."""
        previous, engine_pose = self._pair, self.at_images
        assert engine_pose is not None
        if previous is None:
            return pose, 0
        turn, evaluations = self._heading.turn(previous, pair, engine_pose, pose, population)
        if turn is None:
            return pose, evaluations
        pose = Pose2D(pose.x, pose.y, wrap_angle(pose.theta + turn))
        self._correction = compose(pose, inverse(odometry))
        newest = self._history[-1]
        self._odom = OdomReading(newest.stamp_ns, self._corrected(newest.pose))
        return pose, evaluations
