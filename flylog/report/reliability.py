"""A run page's reliability diagram: does a fly's confidence mean what it says? Per
equal-width confidence bin (flylog.metrics.calibration.reliability), the share of its
flies within tau of the true surface against their mean confidence, beside the diagonal
of a perfect calibration, and how many flies each bin holds."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from flylog.experiments.plots import pyplot, save_figure
from flylog.report.html import Page


def reliability_figure(path: Path, rows: list[dict[str, Any]]) -> Path:
    """Two panels: share on a surface against mean confidence per bin (dots sized by the
    bin's flies, the diagonal dashed), and the flies per bin."""
    plt = pyplot()
    low = np.array([r["bin_low"] for r in rows], dtype=float)
    high = np.array([r["bin_high"] for r in rows], dtype=float)
    flies = np.array([r["flies"] for r in rows], dtype=float)
    mean = np.array([r["mean_confidence"] for r in rows], dtype=float)
    share = np.array([r["on_surface_share"] for r in rows], dtype=float)
    fig, (ax, count) = plt.subplots(
        2, 1, figsize=(4.6, 5.0), sharex=True, gridspec_kw={"height_ratios": (3, 1)}
    )
    ax.plot([0, 1], [0, 1], color="grey", ls="--", lw=1.0, label="perfect calibration")
    seen = flies > 0
    sizes = 12 + 120 * flies[seen] / max(1.0, flies.max())
    ax.plot(mean[seen], share[seen], color="tab:blue", lw=1.0)
    ax.scatter(mean[seen], share[seen], s=sizes, color="tab:blue", label="flies of a bin")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.set_ylabel("share on a true surface")
    ax.grid(True, linewidth=0.3)
    ax.legend(fontsize=8, loc="upper left")
    count.bar(low, flies, width=high - low, align="edge", color="tab:blue", alpha=0.6)
    count.set_xlabel("confidence")
    count.set_ylabel("flies")
    count.grid(True, axis="y", linewidth=0.3)
    fig.tight_layout()
    return save_figure(fig, path)


def reliability_section(
    page: Page, rows: list[dict[str, Any]], summary: dict[str, Any], here: Path
) -> None:
    """The page's "Confidence" section: the diagram and its expected calibration error, or
    a note saying why there is none."""
    page.heading("Confidence")
    flies = sum(int(r["flies"]) for r in rows)
    if not flies:
        page.note(
            "No reliability diagram: the run has no judged flies with a confidence (an SGBM "
            "run, a run without /flies, or no confidence model packaged)."
        )
        return
    ece = summary.get("confidence_ece", math.nan)
    ece_text = "" if ece is None or not math.isfinite(ece) else f"; its ECE is {ece:.3f}"
    page.figure(
        reliability_figure(here / "reliability.png", rows),
        f"Reliability of the flies' confidence over {flies} judged flies, in "
        f"{len(rows)} equal-width bins: a bin on the diagonal holds as many flies on a true "
        "surface as its confidence promises; the expected calibration error (ECE) is the "
        f"flies' mean distance from it{ece_text}.",
    )
