"""``flylog metrics`` on an imported dataset's log: a run scored against the log's
ground-truth disparity (``/truth/disparity``) or depth (``/truth/depth``) images instead of
a rendered scene.

Definitions: :mod:`flylog.metrics.image_truth`. The points scored are the run's obstacle
flies (its ``[obstacles]`` rule; a log without robot geometry has no ground plane, so the
rule's ground test is off) or, for ``stereo = "sgbm"`` runs, its points through the same
rule. Each snapshot is scored against the newest ground-truth image at or before it, while
no newer stereo frame has come (snapshots of frames without ground truth are not scored), and
the summary pools, for each ground-truth image, the last snapshot scored against it: the
population once the engine has worked on that frame. An SGBM run is also scored densely:
the run's SGBM matcher on each ground-truth frame's pair, at every ground-truth pixel.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from flylog.baseline.config import SgbmConfig
from flylog.config import from_mapping
from flylog.io import contract, open_log
from flylog.io.tables import table_row
from flylog.metrics import tables
from flylog.metrics.config import MetricsConfig
from flylog.metrics.flies import f_score
from flylog.metrics.image_truth import (
    BAD1_PX,
    BAD2_PX,
    ImageScore,
    read_disparity_truth,
    score_dense,
    score_points,
)
from flylog.metrics.result import MetricsResult, run_facts
from flylog.sources.inputs import log_rig


def _median(values: np.ndarray) -> float:
    return float(np.median(values)) if len(values) else math.nan


def _share(values: np.ndarray, above: float) -> float:
    return float(np.mean(values > above)) if len(values) else math.nan


def error_columns(score: ImageScore) -> dict[str, float]:
    """The disparity columns of a score: median error, bad1, bad2, coverage."""
    d = score.disparity_errors
    return {
        "disparity_error_median_px": _median(d),
        "bad1": _share(d, BAD1_PX),
        "bad2": _share(d, BAD2_PX),
        "coverage": score.coverage,
    }


def _row(columns: tuple[tables.Column, ...], **values: Any) -> dict[str, Any]:
    """A row of ``columns``: ``values``, nulls elsewhere (ValueError for a value of no
    column)."""
    return table_row(columns, {**{c.name: None for c in columns}, **values})


def _sgbm_dense(
    log: Path,
    config: SgbmConfig,
    stamps: np.ndarray,
    truth: list[np.ndarray],
    rig: Any,
    metrics: MetricsConfig,
) -> dict[str, float]:
    """The dense map's columns: SGBM on each ground-truth frame, pooled over them."""
    from flylog.baseline.sgbm import disparity_px, grey_levels, stereo_matcher

    matcher = stereo_matcher(config, rig.doffs)
    wanted = {int(t): k for k, t in enumerate(stamps)}
    errors, known, matched = [], 0, 0
    for pair in open_log(log).stereo_pairs():
        k = wanted.get(pair.stamp_ns)
        if k is None:
            continue
        left, right = pair.left, pair.right
        if config.grey:
            left, right = grey_levels(left), grey_levels(right)
        dense = disparity_px(matcher, left, right)
        score = score_dense(dense, truth[k], rig, metrics)
        errors.append(score.disparity_errors)
        known += int(np.isfinite(truth[k]).sum())
        matched += score.scored
    d = np.concatenate(errors) if errors else np.empty(0)
    return {
        "sgbm_dense_error_median_px": _median(d),
        "sgbm_dense_bad1": _share(d, BAD1_PX),
        "sgbm_dense_bad2": _share(d, BAD2_PX),
        "sgbm_dense_density": matched / known if known else math.nan,
    }


def score_image_run(run: str | Path, log: str | Path, config: MetricsConfig) -> MetricsResult:
    """Score ``run`` against ``log``'s ground-truth disparity (a MetricsResult)."""
    wall0 = time.perf_counter()
    reader, sensor = open_log(run), open_log(log)
    facts = run_facts(reader, config)
    meta = reader.metadata().get(contract.REPLAY_METADATA, {})
    dataset = sensor.metadata().get(contract.DATASET_METADATA, {})
    mounted = dataset.get("mount") != contract.MOUNT_NONE
    rule = facts.rule
    if not mounted or meta.get("ground_test") == "false":
        rule = dataclasses.replace(rule, ground_margin=-math.inf)
    rig = log_rig(sensor, mounted=mounted)
    truth = read_disparity_truth(sensor, rig)
    rows: list[dict[str, Any]] = []
    last: dict[int, ImageScore] = {}  # ground-truth image → its last snapshot's score
    t0 = int(truth.stamps_ns[0])
    present = reader.topics()
    if contract.FLIES in present:
        for m in reader.messages([contract.FLIES]):
            cloud = m.value
            keep = rule.mask(cloud.xyz, cloud.fitness, cloud.age, cloud.distinct)
            k = truth.at(m.log_time_ns)
            if k is None:  # no ground truth of the frame this snapshot's flies work on
                continue
            score = score_points(cloud.xyz[keep], truth.images[k], rig, config)
            last[k] = score
            row = _row(
                tables.SNAPSHOT_COLUMNS,
                stamp_ns=m.log_time_ns,
                t_s=(m.log_time_ns - t0) / 1e9,
                flies=len(cloud.xyz),
                obstacle_flies=int(keep.sum()),
                in_view=score.scored,
                on_surface=score.on_surface,
                visible_cells=score.truth_cells,
                covered_cells=score.covered_cells,
                precision=score.precision,
                recall=score.recall,
                f_score=f_score(score.precision, score.recall),
                median_depth_error=_median(score.depth_errors),
                **error_columns(score),
            )
            rows.append(row)
    scores = list(last.values())

    def total(key: str) -> int:
        return sum(getattr(s, key) for s in scores)

    precision = total("on_surface") / total("scored") if total("scored") else math.nan
    recall = total("covered_cells") / total("truth_cells") if total("truth_cells") else math.nan
    pooled = ImageScore(
        points=total("points"),
        in_view=total("in_view"),
        scored=total("scored"),
        on_surface=total("on_surface"),
        truth_cells=total("truth_cells"),
        covered_cells=total("covered_cells"),
        close_cells=total("close_cells"),
        disparity_errors=np.concatenate([s.disparity_errors for s in scores] or [np.empty(0)]),
        depth_errors=np.concatenate([s.depth_errors for s in scores] or [np.empty(0)]),
    )
    summary = _row(
        tables.SUMMARY_COLUMNS,
        run=str(run),
        log=str(log),
        snapshots=len(rows),
        truth_images=len(truth.images),
        scored_points=pooled.scored,
        precision=precision,
        recall=recall,
        f_score=f_score(precision, recall),
        median_depth_error=_median(pooled.depth_errors),
        **error_columns(pooled),
        generations=facts.generations,
        evaluations=facts.evaluations,
        evaluations_per_s=(
            facts.evaluations / facts.wall_seconds
            if facts.evaluations is not None and facts.wall_seconds
            else math.nan
        ),
        wall_s=math.nan if facts.wall_seconds is None else facts.wall_seconds,
        log_duration_s=math.nan if facts.log_duration is None else facts.log_duration,
    )
    run_config = json.loads(meta.get("config", "{}"))
    if run_config.get("stereo") == "sgbm":
        sgbm = from_mapping(
            SgbmConfig, run_config.get("sgbm", {}), source=f"{run}: metadata", prefix="sgbm"
        )
        summary.update(_sgbm_dense(Path(log), sgbm, truth.stamps_ns, truth.images, rig, config))
    summary["metrics_wall_s"] = time.perf_counter() - wall0
    return MetricsResult(rows, [], summary, config)
