"""flylog.io: the MCAP contract (``contract``), encoders (``encode``), the atomic
``LogWriter`` and the streaming ``open_log`` reader with its decoders (``decode``).

The names below are imported on first use (PEP 562): reading a log (``open_log``) does not
import the writing side (``LogWriter`` and mcap's writer).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from flylog.lazy import lazy_names

if TYPE_CHECKING:
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
    from flylog.io.scan import DamagedLogWarning, TruncatedLogWarning
    from flylog.io.writer import Compression, LogConfig, LogWriter

# public name → the submodule defining it
_WHERE = {
    "UnpairedImagesWarning": "pairing",
    "pair_stereo": "pairing",
    "LogReader": "reader",
    "open_log": "reader",
    "require_topics": "reader",
    "BoxShape": "records",
    "Calibration": "records",
    "CylinderShape": "records",
    "FlyCloud": "records",
    "GridValues": "records",
    "LogAttachment": "records",
    "LogMessage": "records",
    "Overlay": "records",
    "TopicInfo": "records",
    "Transform": "records",
    "DamagedLogWarning": "scan",
    "TruncatedLogWarning": "scan",
    "Compression": "writer",
    "LogConfig": "writer",
    "LogWriter": "writer",
}

__all__ = [
    "BoxShape",
    "Calibration",
    "Compression",
    "CylinderShape",
    "DamagedLogWarning",
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


__getattr__, __dir__ = lazy_names(__name__, _WHERE)
