"""What replay needs to know about a log before streaming it, from the contract's sensor
topics only (never ``/truth/``): the stereo rig, the frame period, the start and the goal.

An imported dataset's log (``flylog.dataset`` metadata) may lack what a robot gives: without
``/odom`` replay starts at the odometric origin and runs without proprioception; with
``mount = "none"`` (no ``/tf``) the cameras' midpoint sits at base_link's origin, level, and
there is no ground plane (the obstacle rule's ground test is off); without ``--goal`` and a
goal in the log there is no planner. Each of these warns. A log of one stereo pair lasts one
frame period from its stamp, so the default asynchronous replay gives the engine one frame
period of virtual compute on it (``evals_per_second`` / ``frame_rate`` fitness evaluations).

The cameras' row period is the log's ``flylog.shutter`` record's, 0 (a global shutter)
without one, unless replay is given one (``row_period_us``, the command line's
``--row-period``), which holds for any input: a log, an imported dataset's log or a ROS 2 bag.
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass

import numpy as np

from flylog.errors import ConfigError, LogError
from flylog.geometry import Pose2D, StereoRig
from flylog.geometry.calibrated import Mount, calibrated_rig
from flylog.geometry.stereo import OPTICAL_TO_BASE, quaternion_matrix
from flylog.io import contract
from flylog.io.reader import LogReader, require_topics
from flylog.io.shutter import readout_excess, row_period_ns

# Topics replay reads; /truth/ is deliberately absent.
SENSOR_TOPICS = (contract.LEFT_IMAGE, contract.RIGHT_IMAGE, contract.SONAR, contract.ODOM)
REQUIRED_TOPICS = (
    contract.LEFT_IMAGE,
    contract.RIGHT_IMAGE,
    contract.LEFT_CALIBRATION,
    contract.RIGHT_CALIBRATION,
)


class NoSonarWarning(UserWarning):
    """The log has no /sonar topic: the engine runs without sonar fusion."""


class DatasetLogWarning(UserWarning):
    """An imported dataset's log lacks odometry, a robot mount or a goal: replay runs
    without proprioception, without the ground test or without a planner."""


class ShutterOverrideWarning(UserWarning):
    """A log's flylog.shutter record gives another row period than the one replay is given:
    replay uses the given one."""


@dataclass(frozen=True)
class ReplayInputs:
    rig: StereoRig
    frame_period_ns: int
    start: Pose2D  # first odometric pose
    goal: tuple[float, float]  # (start's x, y) when there is no planner
    start_ns: int
    end_ns: int
    has_sonar: bool
    has_ground: bool = True  # the rig's mount is known: z = 0 is the ground
    has_planner: bool = True  # a goal was given or recorded
    frames: int = 0  # stereo pairs in the log
    # rolling shutter: row v of an image is exposed at its stamp + v · row_period_ns (0: a
    # global shutter, every row at the stamp; logs without the record, bags, datasets), or
    # the row period replay is given
    row_period_ns: float = 0.0


def given_row_period_ns(row_period_us: float, rig: StereoRig, *, where: str) -> float:
    """The row period (ns) of ``row_period_us`` given for the input at ``where``, whose
    images ``rig`` reads: ConfigError naming the parameter ``row_period_us`` when it is
    negative or not finite, or when the image's rows take longer than a frame period to read
    out (:func:`flylog.io.shutter.readout_excess`)."""
    if not (math.isfinite(row_period_us) and row_period_us >= 0.0):
        msg = (
            f"the row period must be a finite number of microseconds >= 0 (0: a global "
            f"shutter), got {row_period_us!r}"
        )
        raise ConfigError(msg, parameter="row_period_us")
    excess = readout_excess(row_period_us, rig.height, rig.frame_rate)
    if excess is not None:
        msg = f"the row period given for {where}: {excess}"
        raise ConfigError(msg, parameter="row_period_us")
    return row_period_us * 1000.0


def log_row_period_ns(reader: LogReader, rig: StereoRig, row_period_us: float | None) -> float:
    """The row period (ns) replay reads ``reader``'s images with: the one given
    (``row_period_us``, :func:`given_row_period_ns`), else the log's flylog.shutter record's
    (0 without one). A record that gives another value than the one given, or a malformed
    one, warns, naming the log and both values: the given one wins."""
    where = str(reader.path)
    if row_period_us is None:
        return row_period_ns(reader.metadata(), where=where)
    given = given_row_period_ns(row_period_us, rig, where=where)
    record = reader.metadata().get(contract.SHUTTER_METADATA)
    if record is None:
        return given
    try:
        recorded = row_period_ns(reader.metadata(), where=where)
        says = f"{recorded / 1000.0:g} us"
    except LogError:
        recorded, says = math.nan, f"{record.get('row_period_ns', '')!r} ns (not a row period)"
    if recorded != given:
        msg = (
            f"{where}: its {contract.SHUTTER_METADATA} record gives a row period of {says}; "
            f"replaying with the {row_period_us:g} us given (--row-period) instead"
        )
        warnings.warn(msg, ShutterOverrideWarning, stacklevel=3)
    return given


def replay_inputs(
    reader: LogReader, *, goal: tuple[float, float] | None, row_period_us: float | None = None
) -> ReplayInputs:
    """Read the rig (calibration + static transforms), timing, start and goal of a log; its
    row period is ``row_period_us`` when given (:func:`log_row_period_ns`)."""
    dataset = reader.metadata().get(contract.DATASET_METADATA)
    # a robot's log has odometry and the cameras' mount; a dataset's may have neither
    robot = () if dataset is not None else (contract.ODOM, contract.TF)
    require_topics(reader, REQUIRED_TOPICS + robot)
    topics = reader.topics()
    has_sonar = contract.SONAR in topics
    if has_sonar:
        require_topics(reader, [contract.SONAR])
    else:
        msg = f"{reader.path} has no {contract.SONAR} topic: replaying without sonar fusion"
        warnings.warn(msg, NoSonarWarning, stacklevel=2)
    no_mount = dataset is not None and dataset.get("mount") == contract.MOUNT_NONE
    rig = log_rig(reader, mounted=not no_mount)
    if no_mount:
        msg = (
            f"{reader.path} gives no robot geometry (the dataset has no camera mount): the "
            f"cameras sit at base_link's origin, level, and the obstacle rule has no ground test"
        )
        warnings.warn(msg, DatasetLogWarning, stacklevel=2)
    if contract.ODOM in topics:
        require_topics(reader, [contract.ODOM])
        start = next(iter(reader.messages([contract.ODOM]))).value.pose
    else:
        start = Pose2D(0.0, 0.0, 0.0)
        msg = f"{reader.path} has no {contract.ODOM} topic: replaying without proprioception"
        warnings.warn(msg, DatasetLogWarning, stacklevel=2)
    planner = True
    if goal is None:
        meta = reader.metadata().get(contract.SIMULATION_METADATA, {})
        if "goal" in meta:
            goal = tuple(float(v) for v in json.loads(meta["goal"]))  # type: ignore[assignment]
        elif dataset is not None:
            planner, goal = False, (start.x, start.y)
            msg = (
                f"{reader.path} has no goal: replaying without a planner (a goal given to "
                f"replay turns it on)"
            )
            warnings.warn(msg, DatasetLogWarning, stacklevel=2)
        else:
            msg = (
                f"{reader.path} does not say where the goal is (no 'goal' in its "
                f"flylog.simulation metadata): the goal must be given"
            )
            raise LogError(msg, parameter="goal")
    assert goal is not None
    if len(goal) != 2 or not all(math.isfinite(v) for v in goal):
        msg = f"the goal must be two finite coordinates x, y in metres, got {list(goal)}"
        raise LogError(msg, parameter="goal")
    frames = topics[contract.LEFT_IMAGE].count
    period = round(1e9 / rig.frame_rate)
    end_ns = reader.end_ns if frames > 1 else reader.start_ns + period
    return ReplayInputs(
        rig=rig,
        frame_period_ns=period,
        start=start,
        goal=(float(goal[0]), float(goal[1])),
        start_ns=reader.start_ns,
        end_ns=end_ns,
        has_sonar=has_sonar,
        has_ground=not no_mount,
        has_planner=planner,
        frames=frames,
        row_period_ns=log_row_period_ns(reader, rig, row_period_us),
    )


def log_rig(reader: LogReader, *, mounted: bool = True) -> StereoRig:
    """The rig from the first calibrations (their P matrices) and the static base_link →
    camera transforms (:func:`flylog.geometry.calibrated.calibrated_rig`); not ``mounted``
    (a dataset that gives no mount): the optical centres' midpoint at base_link's origin,
    the optical axes level along x."""
    calib = {}
    for side, topic in contract.CALIBRATION_TOPICS.items():
        calib[side] = next(iter(reader.messages([topic]))).value
    left, right = calib["left"], calib["right"]
    n = reader.topics()[contract.LEFT_IMAGE].count
    span = reader.end_ns - reader.start_ns
    frame_rate = 1e9 * (n - 1) / span if n > 1 and span > 0 else 15.0
    size = (left.width, left.height)
    where, calibration = (
        str(reader.path),
        f"{contract.LEFT_CALIBRATION} and {contract.RIGHT_CALIBRATION}",
    )
    if not mounted:
        half_b = -float(right.P[0, 3]) / float(right.P[0, 0]) / 2.0
        level = Mount(np.array([0.0, half_b, 0.0]), OPTICAL_TO_BASE.copy())
        return calibrated_rig(
            size,
            left.P,
            right.P,
            level,
            None,
            frame_rate,
            where=where,
            calibration=calibration,
            transforms=contract.TF,
        )
    require_topics(reader, [contract.TF])
    mounts: dict[str, Mount] = {}
    for m in reader.messages([contract.TF]):
        for t in m.value:
            if t.parent == contract.BASE_FRAME and t.child in contract.CAMERA_FRAMES.values():
                mounts[t.child] = Mount(
                    np.array(t.translation, float), quaternion_matrix(t.rotation)
                )
        if len(mounts) == 2:
            break
    if len(mounts) < 2:
        msg = (
            f"{reader.path}: {contract.TF} never gives base_link → camera_left and camera_right; "
            f"replay needs them to place the cameras on the robot"
        )
        raise LogError(msg)
    return calibrated_rig(
        size,
        left.P,
        right.P,
        mounts[contract.CAMERA_FRAMES["left"]],
        mounts[contract.CAMERA_FRAMES["right"]],
        frame_rate,
        where=where,
        calibration=calibration,
        transforms=contract.TF,
    )
