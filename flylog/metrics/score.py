"""``flylog metrics``: score a run against its sensor log's truth, the scene
(:mod:`flylog.metrics.scene_score`) or ground-truth images (:mod:`flylog.metrics.image_run`),
with the confidence's calibration (:mod:`flylog.metrics.calibration`); the input's format is
decided by :func:`flylog.sources.input_at`. The result's tables: :mod:`flylog.metrics.write`.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from flylog.config import to_mapping
from flylog.fly import confidence
from flylog.io import contract, open_log
from flylog.io.reader import LogReader
from flylog.io.tables import table_row
from flylog.metrics import tables
from flylog.metrics.calibration import score_confidence
from flylog.metrics.config import MetricsConfig
from flylog.metrics.image_run import score_image_run
from flylog.metrics.provenance import check_run_log, config_digest, run_config_digest
from flylog.metrics.result import MetricsResult
from flylog.metrics.scene_score import score_scene
from flylog.sources import input_at

# Run messages decoded ahead of the scoring by a background thread (a /flies snapshot of
# 5000 flies is ~100 kB): the run's chunks decompress and pass their CRC checks, which
# release the GIL, while the truth is read and views render.
_READ_AHEAD = 64


def score_run(
    run: str | Path,
    log: str | Path,
    config: MetricsConfig = MetricsConfig(),  # noqa: B008 (frozen, immutable)
    *,
    on_progress: Callable[[float, float], None] | None = None,
) -> MetricsResult:
    """Score ``run`` against the ground truth of the sensor log ``log`` (may be the same
    file): its scene, or its ground-truth disparity images (an imported dataset's log,
    :mod:`flylog.metrics.image_run`). ``on_progress(done, total)`` reports progress in
    seconds of log time."""
    wall0 = time.perf_counter()
    reader = open_log(run)
    replayed = reader.metadata().get(contract.REPLAY_METADATA, {})
    fingerprint = check_run_log(run, log, replayed)  # before any work: the right log?
    source = input_at(log)
    if source.image_truth():
        result: MetricsResult = score_image_run(run, log, config)
        return _with_confidence(result, run, log, reader)
    provenance = {
        "log_fingerprint": fingerprint,
        "run_config": run_config_digest(replayed),
        "metrics_config": config_digest(to_mapping(config)),
    }
    present = reader.topics()
    topics = [t for t in (contract.FLIES, contract.PLANNER_COMMAND) if t in present]
    # Reading starts now, in its thread (the first message read here starts it).
    messages = reader.messages(topics, read_ahead=_READ_AHEAD) if topics else None
    first = next(messages, None) if messages is not None else None
    try:
        ahead = [] if first is None else [first]
        stream = itertools.chain(ahead, () if messages is None else messages)
        result = score_scene(run, log, source.truth(), config, reader, stream, on_progress, wall0)
        result = dataclasses.replace(result, summary={**result.summary, **provenance})
        return _with_confidence(result, run, log, reader)
    finally:
        if messages is not None:
            messages.close()  # stops the reading thread if scoring failed


def _with_confidence(
    result: MetricsResult, run: str | Path, log: str | Path, reader: LogReader
) -> MetricsResult:
    """``result`` with the packaged confidence model's calibration on the run's flies
    (:mod:`flylog.metrics.calibration`): the summary's ``confidence_ece`` and
    ``confidence_flies`` (NaN and 0 without /flies or without a model) and the reliability
    table."""
    model = confidence.load()
    if model is None or contract.FLIES not in reader.topics():
        confidence_columns = {"confidence_ece": math.nan, "confidence_flies": 0}
        return dataclasses.replace(result, summary=_summary(result, confidence_columns))
    score = score_confidence(run, log, result.config, model)
    confidence_columns = {"confidence_ece": score.ece, "confidence_flies": score.flies}
    summary = _summary(result, confidence_columns)
    return dataclasses.replace(result, summary=summary, reliability=score.table)


def _summary(result: MetricsResult, confidence_columns: dict[str, Any]) -> dict[str, Any]:
    """The summary row, complete: every column of SUMMARY_COLUMNS and no other."""
    return table_row(tables.SUMMARY_COLUMNS, {**result.summary, **confidence_columns})
