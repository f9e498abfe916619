"""flylog.io: the MCAP contract (``contract``), encoders (``encode``), the atomic
``LogWriter`` and the streaming ``open_log`` reader with its decoders (``decode``).

The names below are imported on first use (PEP 562): reading a log (``open_log``) does not
import the writing side (``LogWriter`` and mcap's writer).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

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
    from flylog.io.scan import TruncatedLogWarning
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


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        msg = f"module {__name__!r} has no attribute {name!r}"
        raise AttributeError(msg)
    value = getattr(importlib.import_module(f"{__name__}.{_WHERE[name]}"), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_WHERE})
