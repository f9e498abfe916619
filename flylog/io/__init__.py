"""flylog.io: the MCAP contract (``contract``), encoders (``encode``), the atomic
``LogWriter`` and the streaming ``open_log`` reader with its decoders (``decode``)."""

from flylog.io.pairing import UnpairedImagesWarning, pair_stereo
from flylog.io.reader import LogReader, open_log, require_topics
from flylog.io.records import (
    BoxShape,
    Calibration,
    CylinderShape,
    FlyCloud,
    GridValues,
    LogAttachment,
    LogMessage,
    Overlay,
    TopicInfo,
    Transform,
)
from flylog.io.scan import TruncatedLogWarning
from flylog.io.writer import Compression, LogConfig, LogWriter

__all__ = [
    "BoxShape",
    "Calibration",
    "Compression",
    "CylinderShape",
    "FlyCloud",
    "GridValues",
    "LogAttachment",
    "LogConfig",
    "LogMessage",
    "LogReader",
    "LogWriter",
    "Overlay",
    "TopicInfo",
    "Transform",
    "TruncatedLogWarning",
    "UnpairedImagesWarning",
    "open_log",
    "pair_stereo",
    "require_topics",
]
