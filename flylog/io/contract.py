"""The MCAP contract: every topic, schema and frame name flylog writes or reads, once.

Foxglove protobuf schemas wherever one fits (so a log opens in Foxglove as it is); JSON
with a named JSON Schema (``flylog.SonarRanges``, ``flylog.Command``) where none fits.
Ground truth lives under ``/truth/``; the replay engine never reads it.
"""

from __future__ import annotations

import enum
import itertools
import json
import zlib
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

# ---- topics ------------------------------------------------------------------------------

LEFT_IMAGE = "/camera/left/image"
RIGHT_IMAGE = "/camera/right/image"
LEFT_CALIBRATION = "/camera/left/calibration"
RIGHT_CALIBRATION = "/camera/right/calibration"
SONAR = "/sonar"
ODOM = "/odom"
TF = "/tf"
TRUTH_POSE = "/truth/pose"
TRUTH_SCENE = "/truth/scene"
# An imported dataset's ground truth: the left image's disparity (px, uL − uR, the rig's
# convention: f·B/Z − doffs), 32FC1, NaN where the dataset gives none.
TRUTH_DISPARITY = "/truth/disparity"
# ... or its depth along the left optical axis (m), 32FC1, NaN where unknown.
TRUTH_DEPTH = "/truth/depth"
FLIES = "/flies"
FLIES_OVERLAY = "/flies/overlay"
PLANNER_POTENTIAL = "/planner/potential"
PLANNER_PATH = "/planner/path"
# The planner's obstacle map: uint8 "occupancy", 100 a detected cell, 99 its inflation by the
# robot's footprint (what the harmonic field also treats as obstacle), 0 free.
PLANNER_MAP = "/planner/map"
PLANNER_COMMAND = "/planner/command"

TRUTH_PREFIX = "/truth/"
# Made by the reader (flylog.io.pairing), never written: left and right images paired.
STEREO_PAIRS = "/camera/stereo"
STEREO_PAIR = "flylog.StereoPair"
IMAGE_TOPICS = MappingProxyType({"left": LEFT_IMAGE, "right": RIGHT_IMAGE})
CALIBRATION_TOPICS = MappingProxyType({"left": LEFT_CALIBRATION, "right": RIGHT_CALIBRATION})

# ---- metadata records -------------------------------------------------------------------

SIMULATION_METADATA = "flylog.simulation"  # scene, seed, camera, start and goal of a sensor log
REPLAY_METADATA = "flylog.replay"  # effective configuration and counts of a run
# The whole /truth/pose and /odom series of a sensor log, written by the simulator at close
# so that metrics read them from the summary section instead of decompressing every image
# chunk. Keys: "version" ("1"), "true" and "odom", each the JSON text of
# {"t_ns": [int], "x": [m], "y": [m], "theta": [rad]}: one entry per message of the topic,
# in log-time order. Logs without it (older or unfinished ones) are read from the topics.
TRAJECTORIES_METADATA = "flylog.trajectories"
TRAJECTORIES_VERSION = "1"
# The cameras' rolling shutter, written by the simulator when its cameras have one: keys
# "version" ("1") and "row_period_ns", the decimal text of a float, the time from one image
# row's exposure to the next's. An image's stamp is the exposure middle of its row 0; row v's
# is the stamp + v · row_period_ns (Kalibr's rolling-shutter "line delay"). A log without the
# record (a global shutter, an imported dataset, a ROS 2 bag) reads as 0: every row at the
# stamp.
SHUTTER_METADATA = "flylog.shutter"
SHUTTER_VERSION = "1"
# What ``flylog import`` read (keys: "format", "source", "scene", "frames") and the robot
# geometry the dataset gives: "mount" is "none" when the dataset does not say where the
# cameras sit on a robot. Such a log has no /tf, no /odom and no ground plane: replay places
# the cameras' midpoint at base_link's origin, level, and the obstacle rule has no ground test.
DATASET_METADATA = "flylog.dataset"
MOUNT_NONE = "none"

# MCAP gives metadata records no checksum; flylog's writer adds one to each record it
# writes: the key below, whose value is the CRC-32 (zlib's) of the record's name and its
# other keys and values in key order, each as a little-endian u32 byte length and its UTF-8
# bytes, written as 8 lowercase hex digits. The reader checks it and skips (with a warning)
# a record whose checksum does not match, or that lacks one in a log whose header's library
# field ends with METADATA_CRC_MARK (every record of such a log carries it); a record of
# another log without the key is read as it is. Readers never see the key.
METADATA_CRC_KEY = "flylog.crc32"
METADATA_CRC_MARK = "+metadata-crc32"


def metadata_crc(name: str, values: Mapping[str, str]) -> str:
    """The checksum METADATA_CRC_KEY holds for the metadata record ``name`` of ``values``
    (the key itself, if present, is left out)."""
    pairs = sorted((k, v) for k, v in values.items() if k != METADATA_CRC_KEY)
    crc = 0
    for text in (name, *itertools.chain.from_iterable(pairs)):
        data = text.encode("utf-8", "surrogatepass")
        crc = zlib.crc32(data, zlib.crc32(len(data).to_bytes(4, "little"), crc))
    return f"{crc:08x}"


# ---- frames ------------------------------------------------------------------------------

ODOM_FRAME = "odom"
BASE_FRAME = "base_link"
CAMERA_FRAMES = MappingProxyType({"left": "camera_left", "right": "camera_right"})


def sonar_frame(index: int) -> str:
    """Frame id of the ``index``-th transducer of the sonar ring (``sonar_0`` …)."""
    return f"sonar_{index}"


# ---- schemas -----------------------------------------------------------------------------

RAW_IMAGE = "foxglove.RawImage"
CAMERA_CALIBRATION = "foxglove.CameraCalibration"
POSE_IN_FRAME = "foxglove.PoseInFrame"
FRAME_TRANSFORMS = "foxglove.FrameTransforms"
SCENE_UPDATE = "foxglove.SceneUpdate"
POINT_CLOUD = "foxglove.PointCloud"
IMAGE_ANNOTATIONS = "foxglove.ImageAnnotations"
GRID = "foxglove.Grid"
POSES_IN_FRAME = "foxglove.PosesInFrame"
SONAR_RANGES = "flylog.SonarRanges"
COMMAND = "flylog.Command"

PROTOBUF = "protobuf"  # schema and message encoding of the Foxglove schemas
JSON_SCHEMA_ENCODING = "jsonschema"
JSON_MESSAGE_ENCODING = "json"

TOPIC_SCHEMAS: MappingProxyType[str, str] = MappingProxyType(
    {
        LEFT_IMAGE: RAW_IMAGE,
        RIGHT_IMAGE: RAW_IMAGE,
        LEFT_CALIBRATION: CAMERA_CALIBRATION,
        RIGHT_CALIBRATION: CAMERA_CALIBRATION,
        SONAR: SONAR_RANGES,
        ODOM: POSE_IN_FRAME,
        TF: FRAME_TRANSFORMS,
        TRUTH_POSE: POSE_IN_FRAME,
        TRUTH_SCENE: SCENE_UPDATE,
        TRUTH_DISPARITY: RAW_IMAGE,
        TRUTH_DEPTH: RAW_IMAGE,
        FLIES: POINT_CLOUD,
        FLIES_OVERLAY: IMAGE_ANNOTATIONS,
        PLANNER_POTENTIAL: GRID,
        PLANNER_PATH: POSES_IN_FRAME,
        PLANNER_MAP: GRID,
        PLANNER_COMMAND: COMMAND,
    }
)

_FOXGLOVE_CLASSES = {
    RAW_IMAGE: "RawImage",
    CAMERA_CALIBRATION: "CameraCalibration",
    POSE_IN_FRAME: "PoseInFrame",
    FRAME_TRANSFORMS: "FrameTransforms",
    SCENE_UPDATE: "SceneUpdate",
    POINT_CLOUD: "PointCloud",
    IMAGE_ANNOTATIONS: "ImageAnnotations",
    GRID: "Grid",
    POSES_IN_FRAME: "PosesInFrame",
}


def _foxglove_types() -> MappingProxyType[str, Any]:
    # Only writing needs the classes (their schemas): reading decodes by the schema each log
    # carries, and importing the Foxglove SDK costs every reading command ~15 ms.
    import foxglove.messages as fm

    return MappingProxyType({name: getattr(fm, cls) for name, cls in _FOXGLOVE_CLASSES.items()})


def __getattr__(name: str) -> Any:
    if name == "FOXGLOVE_TYPES":  # the Foxglove message class of each protobuf schema
        return _foxglove_types()
    msg = f"module {__name__!r} has no attribute {name!r}"
    raise AttributeError(msg)


class CommandStatus(enum.Enum):
    """What the planner is doing; the ``status`` of a ``flylog.Command``."""

    DRIVING = "driving"
    GOAL_REACHED = "goal_reached"
    STUCK = "stuck"
    UNREACHABLE = "unreachable"


_TIME = {
    "type": "object",
    "title": "time",
    "description": "message time (sec, nsec), the Foxglove JSON time convention",
    "properties": {
        "sec": {"type": "integer", "minimum": 0},
        "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999},
    },
    "required": ["sec", "nsec"],
}

_SONAR_RANGES_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": SONAR_RANGES,
    "description": "One reading cycle of the sonar ring",
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "frame_id": {"type": "string", "description": "frame of the mounts (base_link)"},
        "ranges": {
            "type": "array",
            "description": "measured range of each sonar (m); null where it had no echo",
            "items": {"type": ["number", "null"]},
        },
        "fired": {
            "type": "array",
            "description": "whether each sonar received an echo",
            "items": {"type": "boolean"},
        },
        "cone_angle": {"type": "number", "description": "full opening angle of a cone (rad)"},
        "max_range": {"type": "number", "description": "maximum detection range (m)"},
        "min_range": {"type": "number", "description": "minimum detection range (m)"},
        "mounts": {
            "type": "array",
            "description": "[x (m), y (m), yaw (rad)] of each transducer in frame_id",
            "items": {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3},
        },
    },
    "required": [
        "timestamp",
        "frame_id",
        "ranges",
        "fired",
        "cone_angle",
        "max_range",
        "min_range",
        "mounts",
    ],
}

_COMMAND_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": COMMAND,
    "description": "The velocity command the planner issues",
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "linear": {"type": "number", "description": "forward velocity (m/s)"},
        "angular": {"type": "number", "description": "turn rate, counter-clockwise (rad/s)"},
        "status": {"type": "string", "enum": [s.value for s in CommandStatus]},
    },
    "required": ["timestamp", "linear", "angular", "status"],
}

JSON_SCHEMAS: MappingProxyType[str, bytes] = MappingProxyType(
    {
        SONAR_RANGES: json.dumps(_SONAR_RANGES_SCHEMA, indent=1).encode(),
        COMMAND: json.dumps(_COMMAND_SCHEMA, indent=1).encode(),
    }
)


def schema_record(name: str) -> tuple[str, str, bytes]:
    """(name, schema encoding, schema data) of a contract schema, as MCAP stores it."""
    if name in _FOXGLOVE_CLASSES:
        schema = _foxglove_types()[name].get_schema()
        return schema.name, schema.encoding, schema.data
    if name in JSON_SCHEMAS:
        return name, JSON_SCHEMA_ENCODING, JSON_SCHEMAS[name]
    msg = f"schema '{name}' is not part of the flylog MCAP contract"
    raise KeyError(msg)


def message_encoding(schema_name: str) -> str:
    """The MCAP message encoding of messages with this contract schema."""
    return JSON_MESSAGE_ENCODING if schema_name in JSON_SCHEMAS else PROTOBUF
