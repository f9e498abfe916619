"""The page of a run on an imported dataset's log (Middlebury, KITTI: ground-truth disparity
images, no scene, no trajectory): a headline with the verdict, each obstacle fly's
disparity error drawn on the left image beside the true disparity, the histogram of the
errors, and SGBM's dense map of the same pair with its error, the conventional answer to
compare the flies with.

The flies drawn and counted are those of the last snapshot scored against each
ground-truth image, as the summary pools them (flylog.metrics.image_run); the frame drawn
is the ground-truth image whose last snapshot scored the most flies.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from flylog.report.html import Page

# Errors drawn from 0 (green) to this (red): bad2's threshold times two.
ERROR_SCALE_PX = 4.0
HISTOGRAM_MAX_PX = 10.0
# What the points of a run are called: SGBM's are named as SGBM's, never as flies.
POINTS_FLIES, POINTS_SGBM = "obstacle flies", "SGBM points"


@dataclass(frozen=True)
class FlyErrors:
    """The points of one snapshot against one ground-truth image: left pixels and |error|."""

    stamp_ns: int
    truth_index: int
    u: np.ndarray
    v: np.ndarray
    error_px: np.ndarray  # NaN: no ground truth at that pixel


def fly_errors(run: Path, log: Path) -> tuple[list[FlyErrors], Any, Any]:
    """For each ground-truth image, its last snapshot's obstacle flies (or SGBM points) and
    their disparity errors; the log's rig and ground truth."""
    from flylog.io import contract, open_log
    from flylog.metrics.config import MetricsConfig
    from flylog.metrics.image_truth import read_disparity_truth, truth_at
    from flylog.metrics.score import run_facts
    from flylog.replay.inputs import log_rig

    reader, sensor = open_log(run), open_log(log)
    dataset = sensor.metadata().get(contract.DATASET_METADATA, {})
    mounted = dataset.get("mount") != contract.MOUNT_NONE
    rule = run_facts(reader, MetricsConfig()).rule
    meta = reader.metadata().get(contract.REPLAY_METADATA, {})
    if not mounted or meta.get("ground_test") == "false":
        import dataclasses

        rule = dataclasses.replace(rule, ground_margin=-math.inf)
    rig = log_rig(sensor, mounted=mounted)
    truth = read_disparity_truth(sensor, rig)
    last: dict[int, FlyErrors] = {}
    if contract.FLIES in reader.topics():
        for m in reader.messages([contract.FLIES]):
            k = truth.at(m.log_time_ns)
            if k is None:
                continue
            cloud = m.value
            keep = rule.mask(cloud.xyz, cloud.fitness, cloud.age, cloud.distinct)
            xyz = np.asarray(cloud.xyz[keep], dtype=np.float64).reshape(-1, 3)
            u, ur, v, depth = rig.project(xyz)
            image = truth.images[k]
            h, w = image.shape
            inside = (depth > 0) & (u >= -0.5) & (u < w - 0.5) & (v >= -0.5) & (v < h - 0.5)
            u, ur, v = u[inside], ur[inside], v[inside]
            error = np.abs((u - ur) - truth_at(image, u, v))
            last[k] = FlyErrors(m.log_time_ns, k, u, v, error)
    return [last[k] for k in sorted(last)], rig, truth


def _left_right(log: Path, stamp_ns: int) -> tuple[np.ndarray, np.ndarray]:
    from flylog.io import open_log

    found = None
    for pair in open_log(log).stereo_pairs():
        found = (pair.left, pair.right)
        if pair.stamp_ns >= stamp_ns:
            break
    if found is None:
        msg = f"{log} has no stereo pairs"
        raise ValueError(msg)
    return found


def _sgbm_dense(run: Path, log: Path, truth_stamp: int, rig: Any) -> np.ndarray:
    """SGBM's dense disparity (px, NaN: unmatched) of the pair at ``truth_stamp``, with the
    run's [sgbm] settings (the defaults for a fly run)."""
    from flylog.baseline.config import SgbmConfig
    from flylog.baseline.sgbm import disparity_px, grey_levels, stereo_matcher
    from flylog.config import from_mapping
    from flylog.io import contract, open_log

    meta = open_log(run).metadata().get(contract.REPLAY_METADATA, {})
    sgbm = json.loads(meta.get("config", "{}")).get("sgbm", {})
    config = from_mapping(SgbmConfig, sgbm, source=f"{run}: metadata", prefix="sgbm")
    left, right = _left_right(log, truth_stamp)
    if config.grey:
        left, right = grey_levels(left), grey_levels(right)
    return np.asarray(disparity_px(stereo_matcher(config, rig.doffs), left, right))


def _panels_figure(
    path: Path,
    left: np.ndarray,
    flies: FlyErrors,
    truth: np.ndarray,
    dense: np.ndarray,
    points_label: str,
) -> Path:
    """2×2: the left image with each point's error; the true disparity; SGBM's dense map;
    its error. One disparity scale for the two maps, one error scale for the two errors."""
    from flylog.experiments.plots import pyplot, save_figure

    plt = pyplot()
    h, w = truth.shape
    fig, axes = plt.subplots(2, 2, figsize=(13.0, 13.0 * h / w + 1.2), squeeze=False)
    known = np.isfinite(truth)
    lo, hi = np.nanpercentile(truth, [1, 99]) if known.any() else (0.0, 1.0)
    ax = axes[0][0]
    ax.imshow(left, cmap="gray" if left.ndim == 2 else None)
    ok = np.isfinite(flies.error_px)
    ax.scatter(
        flies.u[~ok], flies.v[~ok], s=7, c="#9a9a9a", linewidths=0, label="no ground truth there"
    )
    dots = ax.scatter(
        flies.u[ok],
        flies.v[ok],
        s=7,
        c=np.minimum(flies.error_px[ok], ERROR_SCALE_PX),
        cmap="RdYlGn_r",
        vmin=0.0,
        vmax=ERROR_SCALE_PX,
        linewidths=0,
    )
    fig.colorbar(dots, ax=ax, fraction=0.046, pad=0.02, label="|disparity error| (px)")
    title = f"{points_label}: {int(ok.sum())} on known truth, coloured by their error"
    ax.set_title(title[:1].upper() + title[1:], fontsize=10)
    ax = axes[0][1]
    shown = ax.imshow(truth, cmap="viridis", vmin=lo, vmax=hi)
    fig.colorbar(shown, ax=ax, fraction=0.046, pad=0.02, label="disparity (px)")
    ax.set_title("ground-truth disparity (blank: unknown)", fontsize=10)
    ax = axes[1][0]
    shown = ax.imshow(dense, cmap="viridis", vmin=lo, vmax=hi)
    fig.colorbar(shown, ax=ax, fraction=0.046, pad=0.02, label="disparity (px)")
    share = float(np.isfinite(dense).mean())
    ax.set_title(f"SGBM's dense map of the same pair ({share:.0%} of pixels matched)", fontsize=10)
    ax = axes[1][1]
    error = np.abs(dense - truth)
    shown = ax.imshow(error, cmap="RdYlGn_r", vmin=0.0, vmax=ERROR_SCALE_PX)
    fig.colorbar(shown, ax=ax, fraction=0.046, pad=0.02, label="|disparity error| (px)")
    ax.set_title("SGBM's error (blank: unmatched or unknown)", fontsize=10)
    for a in axes.ravel():
        a.set_xticks([])
        a.set_yticks([])
    if (~ok).any():
        axes[0][0].legend(loc="lower left", fontsize=8, markerscale=2)
    fig.tight_layout()
    return save_figure(fig, path)


def _histogram_figure(path: Path, errors: Sequence[tuple[str, np.ndarray, str]]) -> Path:
    """The share of points per error bin (0 … HISTOGRAM_MAX_PX px; the last bin holds the
    larger ones), one outline per set of points."""
    from flylog.experiments.plots import pyplot, save_figure

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(12.0, 3.8))
    bins = np.linspace(0.0, HISTOGRAM_MAX_PX, 41)
    for label, values, colour in errors:
        v = np.minimum(values[np.isfinite(values)], HISTOGRAM_MAX_PX)
        if not len(v):
            continue
        weights = np.full(len(v), 1.0 / len(v))
        median = float(np.median(values[np.isfinite(values)]))
        name = f"{label} ({len(v)}; median {median:.2f} px)"
        ax.hist(v, bins=bins, weights=weights, histtype="step", lw=1.8, color=colour, label=name)
    for x, name in ((1.0, "bad1"), (2.0, "bad2")):
        ax.axvline(x, color="grey", lw=0.8, ls=":")
        ax.text(x, ax.get_ylim()[1] * 0.95, f" {name}", fontsize=8, color="grey", va="top")
    ax.set_xlabel(f"|disparity error| (px; the last bin holds every error ≥ {HISTOGRAM_MAX_PX:g})")
    ax.set_ylabel("share of the points")
    ax.set_ylim(bottom=0.0)
    ax.grid(True, linewidth=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path)


def _pct(x: Any) -> str:
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.0%}"


def _px(x: Any) -> str:
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.2f} px"


def headline(summary: dict[str, Any], points_label: str, dataset: str) -> tuple[str, str]:
    """The verdict in a sentence and the key figures, from the summary."""
    bad2, median = summary.get("bad2"), summary.get("disparity_error_median_px")
    sgbm_bad2 = summary.get("sgbm_dense_bad2")
    if bad2 is None or (isinstance(bad2, float) and math.isnan(bad2)):
        verdict = f"None of the {points_label} fell on pixels with ground truth: nothing scored."
    else:
        verdict = (
            f"{1 - bad2:.0%} of the {points_label} lie within 2 px of the true "
            f"disparity (median error {_px(median)}) on {dataset}."
        )
    figures = (
        f"bad1 {_pct(summary.get('bad1'))} · bad2 {_pct(bad2)} · coverage "
        f"{_pct(summary.get('coverage'))} · precision {_pct(summary.get('precision'))} · "
        f"{summary.get('scored_points') or 0} points scored on "
        f"{summary.get('truth_images') or 0} ground-truth image(s)"
    )
    if sgbm_bad2 is not None and not (isinstance(sgbm_bad2, float) and math.isnan(sgbm_bad2)):
        figures += (
            f" · SGBM's dense map: bad2 {_pct(sgbm_bad2)}, median "
            f"{_px(summary.get('sgbm_dense_error_median_px'))}"
        )
    return verdict, figures


def dataset_sections(
    page: Page, run: Path, log: Path, summary: dict[str, Any], here: Path, sgbm_run: bool
) -> None:
    """The figures of an imported dataset's run, added to ``page``."""
    points_label = POINTS_SGBM if sgbm_run else POINTS_FLIES
    snapshots, rig, truth = fly_errors(run, log)
    if not snapshots:
        page.note("No snapshot of the run was scored against a ground-truth image: no frame.")
        return
    best = max(snapshots, key=lambda s: int(np.isfinite(s.error_px).sum()))
    left, _ = _left_right(log, int(truth.stamps_ns[best.truth_index]))
    image = truth.images[best.truth_index]
    dense = _sgbm_dense(run, log, int(truth.stamps_ns[best.truth_index]), rig)
    page.heading("Disparity error on the left image")
    page.figure(
        _panels_figure(here / "dataset.png", left, best, image, dense, points_label),
        f"Top: {points_label} of the last snapshot on this pair at their left "
        f"projections, green (exact) to red (≥ {ERROR_SCALE_PX:g} px off; grey: no ground "
        "truth there), and the true disparity. Bottom: SGBM's dense map of the same pair "
        "(the run's [sgbm] settings) and its error, on the same scales.",
    )
    flies = np.concatenate([s.error_px for s in snapshots])
    dense_error = np.abs(dense - image).ravel()
    page.heading("Error histogram")
    page.figure(
        _histogram_figure(
            here / "histogram.png",
            [
                (points_label[:1].upper() + points_label[1:], flies, "tab:purple"),
                ("SGBM's dense map, this pair", dense_error, "tab:blue"),
            ],
        ),
        f"Share of the points per 0.25 px of |disparity error|: the {points_label} of "
        "the last snapshot on each ground-truth image, and SGBM's dense map of the pair "
        "drawn above; dotted: the bad1 and bad2 thresholds.",
    )
