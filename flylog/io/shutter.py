"""The cameras' rolling shutter in a log: the ``flylog.shutter`` metadata record
(:data:`flylog.io.contract.SHUTTER_METADATA`), written and read.

An image's stamp is the exposure middle of its row 0 and row v's is the stamp + v row
periods; a log without the record reads as a global shutter (row period 0). A rolling shutter
reads every row of a frame within the frame period (:func:`readout_excess`), whoever states
the row period: a scene file's camera model or replay's ``--row-period``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from flylog.errors import LogError
from flylog.io import contract


def shutter_metadata(row_period_ns: float) -> dict[str, str]:
    """The record's keys and values for a row period of ``row_period_ns``."""
    return {"version": contract.SHUTTER_VERSION, "row_period_ns": repr(float(row_period_ns))}


def row_period_ns(metadata: Mapping[str, Mapping[str, str]], *, where: str) -> float:
    """The row period (ns) a log's metadata records (its records by name) give: 0 without
    :data:`~flylog.io.contract.SHUTTER_METADATA`; LogError naming ``where`` and the record
    when its value is not a finite, non-negative number."""
    record = metadata.get(contract.SHUTTER_METADATA)
    if record is None:
        return 0.0
    text = record.get("row_period_ns", "")
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value) or value < 0.0:
        msg = (
            f"{where}: metadata {contract.SHUTTER_METADATA}.row_period_ns is {text!r}, not a "
            "finite number of nanoseconds >= 0"
        )
        raise LogError(msg)
    return value


def readout_excess(row_period_us: float, height: int, frame_rate: float) -> str | None:
    """The figures and the fix when ``height`` rows of ``row_period_us`` take longer to read
    out than a frame period at ``frame_rate`` (Hz), to follow the name of what sets the row
    period in an error; None when the readout fits."""
    period_us = 1e6 / frame_rate
    readout_us = height * row_period_us
    if readout_us <= period_us:
        return None
    return (
        f"{height} rows of {row_period_us:g} us take {readout_us / 1000.0:g} ms to read out, "
        f"longer than the frame period ({period_us / 1000.0:g} ms at {frame_rate:g} Hz); lower "
        f"it to at most {period_us / height:g} us"
    )
