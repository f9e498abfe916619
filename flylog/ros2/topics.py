"""Which topics of a bag play which role: the stereo pair and its calibrations, the
odometry, the sonars.

Without overrides: left and right are the two image topics whose names contain ``left``
and ``right``, each with a ``camera_info`` topic in its namespace; odometry is the one
Odometry topic; the sonars are every Range topic. ``/truth/`` topics are never candidates.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from flylog.errors import LogError
from flylog.io.contract import TRUTH_PREFIX
from flylog.io.records import TopicInfo
from flylog.ros2 import types

ROLES = ("left", "right", "odom", "sonar")


@dataclass(frozen=True)
class Roles:
    """The topics a replay reads."""

    left: str
    right: str
    left_info: str
    right_info: str
    odom: str | None  # None: none (proprioception off)
    odom_from_tf: bool  # odometry is /tf odom → base_link
    sonars: tuple[str, ...]


def parse_overrides(items: tuple[str, ...]) -> dict[str, str]:
    """``role=topic`` items (``sonar=/r0,/r1``) → role → value; LogError for a bad item or
    a role given twice (which of the two is meant cannot be told)."""
    out: dict[str, str] = {}
    for item in items:
        role, sep, value = item.partition("=")
        if not sep or role not in ROLES or not value:
            msg = (
                f"topic override {item!r}: expected ROLE=TOPIC with ROLE one of {', '.join(ROLES)}"
            )
            raise LogError(msg, parameter="topics")
        if role in out:
            msg = f"topic override {item!r}: {role} is given twice ({role}={out[role]} too)"
            raise LogError(msg, parameter="topics")
        out[role] = value
    return out


def _info_topic(image: str, topics: Mapping[str, TopicInfo]) -> str | None:
    """The CameraInfo topic in an image topic's namespace (``/cam/left/image_raw`` →
    ``/cam/left/camera_info``), searching up the namespaces."""
    parts = image.rstrip("/").split("/")[:-1]
    while parts:
        candidate = "/".join([*parts, "camera_info"])
        if topics.get(candidate, TopicInfo("", 0)).schema == types.CAMERA_INFO:
            return candidate
        parts = parts[:-1]
    return None


def _listing(topics: Mapping[str, TopicInfo], wanted: tuple[str, ...]) -> str:
    found = [f"{t} ({i.schema})" for t, i in topics.items() if i.schema in wanted]
    return ", ".join(found) or "none"


def assign_roles(bag: Path, topics: Mapping[str, TopicInfo], overrides: Mapping[str, str]) -> Roles:
    """The bag's roles, or a LogError listing, for each unresolved role, the candidates."""
    seen = {t: i for t, i in topics.items() if not t.startswith(TRUTH_PREFIX)}
    images = [t for t, i in seen.items() if i.schema in types.IMAGE_TYPES]
    problems: list[str] = []
    chosen: dict[str, str] = {}
    for side in ("left", "right"):
        if side in overrides:
            topic = overrides[side]
            if seen.get(topic, TopicInfo("", 0)).schema not in types.IMAGE_TYPES:
                problems.append(f"{side}: {topic} is not an image topic of the bag")
            else:
                chosen[side] = topic
            continue
        named = [t for t in images if side in t.lower() and _info_topic(t, seen)]
        if len(named) == 1:
            chosen[side] = named[0]
        else:
            why = "no image topic with" if not named else "several image topics with"
            problems.append(
                f"{side}: {why} '{side}' in its name and a camera_info beside it "
                f"(candidates: {_listing(seen, types.IMAGE_TYPES)}); choose one "
                f"with the override {side}=TOPIC"
            )
    if chosen.get("left") is not None and chosen.get("left") == chosen.get("right"):
        problems.append(
            f"left and right: both are {chosen['left']}; a stereo pair is two cameras' "
            "topics (override the other with left=TOPIC or right=TOPIC)"
        )
    infos: dict[str, str] = {}
    for side, topic in chosen.items():
        info = _info_topic(topic, seen)
        if info is None:
            problems.append(
                f"{side}: {topic} has no CameraInfo topic in its namespace (CameraInfo "
                f"topics: {_listing(seen, (types.CAMERA_INFO,))})"
            )
        else:
            infos[side] = info
    odom, odom_from_tf = _odometry(seen, overrides, problems)
    sonars = _sonars(seen, overrides, problems)
    if problems:
        msg = f"{bag}: cannot tell which topics to replay:\n  " + "\n  ".join(problems)
        raise LogError(msg, parameter="topics")
    return Roles(
        chosen["left"], chosen["right"], infos["left"], infos["right"], odom, odom_from_tf,
        sonars,
    )  # fmt: skip


def _odometry(
    seen: Mapping[str, TopicInfo], overrides: Mapping[str, str], problems: list[str]
) -> tuple[str | None, bool]:
    if "odom" in overrides:
        topic = overrides["odom"]
        schema = seen.get(topic, TopicInfo("", 0)).schema
        if schema == types.ODOMETRY:
            return topic, False
        if schema == types.TF_MESSAGE and topic == types.TF:
            return topic, True
        problems.append(f"odom: {topic} is neither an Odometry topic of the bag nor /tf")
        return None, False
    found = [t for t, i in seen.items() if i.schema == types.ODOMETRY]
    if len(found) == 1:
        return found[0], False
    if len(found) > 1:
        problems.append(
            f"odom: several Odometry topics (candidates: {_listing(seen, (types.ODOMETRY,))}); "
            f"choose one with the override odom=TOPIC"
        )
        return None, False
    if seen.get(types.TF, TopicInfo("", 0)).schema == types.TF_MESSAGE:
        return types.TF, True
    return None, False


def _sonars(
    seen: Mapping[str, TopicInfo], overrides: Mapping[str, str], problems: list[str]
) -> tuple[str, ...]:
    if "sonar" not in overrides:
        return tuple(t for t, i in seen.items() if i.schema == types.RANGE)
    chosen = tuple(t for t in overrides["sonar"].split(",") if t)
    wrong = [t for t in chosen if seen.get(t, TopicInfo("", 0)).schema != types.RANGE]
    if wrong:
        problems.append(
            f"sonar: {', '.join(wrong)} not Range topics of the bag "
            f"(candidates: {_listing(seen, (types.RANGE,))})"
        )
    return chosen
