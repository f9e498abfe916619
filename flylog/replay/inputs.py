"""What replay needs to know about a log before streaming it, from the contract's sensor
topics only (never ``/truth/``): the stereo rig, the frame period, the start and the goal."""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass

import numpy as np

from flylog.errors import LogError
from flylog.geometry import Pose2D, StereoRig
from flylog.geometry.calibrated import Mount, calibrated_rig
from flylog.geometry.stereo import quaternion_matrix
from flylog.io import contract
from flylog.io.reader import LogReader, require_topics

# Topics replay reads; /truth/ is deliberately absent.
SENSOR_TOPICS = (contract.LEFT_IMAGE, contract.RIGHT_IMAGE, contract.SONAR, contract.ODOM)
REQUIRED_TOPICS = (
    contract.LEFT_IMAGE,
    contract.RIGHT_IMAGE,
    contract.LEFT_CALIBRATION,
    contract.RIGHT_CALIBRATION,
    contract.ODOM,
    contract.TF,
)


class NoSonarWarning(UserWarning):
    """The log has no /sonar topic: the engine runs without sonar fusion."""


@dataclass(frozen=True)
class ReplayInputs:
    rig: StereoRig
    frame_period_ns: int
    start: Pose2D  # first odometric pose
    goal: tuple[float, float]
    start_ns: int
    end_ns: int
    has_sonar: bool


def replay_inputs(reader: LogReader, *, goal: tuple[float, float] | None) -> ReplayInputs:
    """Read the rig (calibration + static transforms), timing, start and goal of a log."""
    require_topics(reader, REQUIRED_TOPICS)
    topics = reader.topics()
    has_sonar = contract.SONAR in topics
    if has_sonar:
        require_topics(reader, [contract.SONAR])
    else:
        msg = f"{reader.path} has no {contract.SONAR} topic: replaying without sonar fusion"
        warnings.warn(msg, NoSonarWarning, stacklevel=2)
    rig = _rig(reader)
    first_odom = next(iter(reader.messages([contract.ODOM]))).value
    if goal is None:
        meta = reader.metadata().get(contract.SIMULATION_METADATA, {})
        if "goal" not in meta:
            msg = (
                f"{reader.path} does not say where the goal is (no 'goal' in its "
                f"flylog.simulation metadata): the goal must be given"
            )
            raise LogError(msg, parameter="goal")
        goal = tuple(float(v) for v in json.loads(meta["goal"]))  # type: ignore[assignment]
    assert goal is not None
    if len(goal) != 2 or not all(math.isfinite(v) for v in goal):
        msg = f"the goal must be two finite coordinates x, y in metres, got {list(goal)}"
        raise LogError(msg, parameter="goal")
    return ReplayInputs(
        rig=rig,
        frame_period_ns=round(1e9 / rig.frame_rate),
        start=first_odom.pose,
        goal=(float(goal[0]), float(goal[1])),
        start_ns=reader.start_ns,
        end_ns=reader.end_ns,
        has_sonar=has_sonar,
    )


def _rig(reader: LogReader) -> StereoRig:
    """The rig from the first calibrations (their P matrices) and the static base_link →
    camera transforms (:func:`flylog.geometry.calibrated.calibrated_rig`)."""
    calib = {}
    for side, topic in contract.CALIBRATION_TOPICS.items():
        calib[side] = next(iter(reader.messages([topic]))).value
    left, right = calib["left"], calib["right"]
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
    n = reader.topics()[contract.LEFT_IMAGE].count
    span = reader.end_ns - reader.start_ns
    frame_rate = 1e9 * (n - 1) / span if n > 1 and span > 0 else 15.0
    return calibrated_rig(
        (left.width, left.height), left.P, right.P,
        mounts[contract.CAMERA_FRAMES["left"]], mounts[contract.CAMERA_FRAMES["right"]],
        frame_rate,
        where=str(reader.path),
        calibration=f"{contract.LEFT_CALIBRATION} and {contract.RIGHT_CALIBRATION}",
        transforms=contract.TF,
    )  # fmt: skip
