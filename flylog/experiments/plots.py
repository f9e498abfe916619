"""The experiments' figures (matplotlib, Agg backend, imported only here and only when a
figure is drawn): top-down maps with obstacles, trajectories and flies; left frames with
the flies overlaid; metric curves over time. PNGs are kept small (about 100 KB)."""

from __future__ import annotations

import io
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from flylog.geometry import StereoRig
from flylog.io.atomic import write_bytes
from flylog.scene.footprints import DISC
from flylog.scene.load import Scene

DPI = 80
COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")


def pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, path: Path) -> Path:
    """Write ``fig`` as PNG atomically (flylog.io.atomic)."""
    image = io.BytesIO()
    fig.savefig(image, format="png", dpi=DPI, bbox_inches="tight")
    pyplot().close(fig)
    write_bytes(path, image.getvalue())
    return path


@dataclass(frozen=True)
class Path2D:
    """A trajectory to draw: (N, 2) points in the world frame."""

    xy: np.ndarray
    label: str | None = None
    colour: str = "tab:green"
    style: str = "-"
    width: float = 1.5


@dataclass(frozen=True)
class MapPanel:
    """One top-down panel: trajectories, flies (world x, y) and optionally the cameras'
    field of view from a pose (x, y, theta)."""

    title: str
    paths: tuple[Path2D, ...] = ()
    flies: np.ndarray | None = None
    flies_label: str = "obstacle flies"
    view_from: tuple[float, float, float] | None = None
    extent: tuple[float, float, float, float] | None = None  # xmin, xmax, ymin, ymax


def draw_scene(ax: Any, scene: Scene) -> None:
    """Obstacle footprints in their colours (untextured ones hatched, sonar-absorbing ones
    dashed), the start and the goal."""
    from matplotlib.patches import Circle, Polygon

    fp = scene.footprints
    for k, ob in enumerate(scene.obstacles):
        colour = tuple(float(c) for c in fp.color[k])
        style = {
            "facecolor": colour,
            "edgecolor": "black",
            "linewidth": 0.6,
            "linestyle": "--" if ob.sonar_absorbing else "-",
            "hatch": "xx" if ob.low_texture else None,
        }
        if fp.kind[k] == DISC:
            ax.add_patch(Circle((fp.cx[k], fp.cy[k]), fp.hx[k], **style))
            continue
        c, s = fp.cos[k], fp.sin[k]
        corners = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]]) * [fp.hx[k], fp.hy[k]]
        rot = corners @ np.array([[c, s], [-s, c]])
        ax.add_patch(Polygon(rot + np.array([fp.cx[k], fp.cy[k]]), closed=True, **style))
    start = scene.start_pose
    ax.plot(start.x, start.y, "k^", markersize=6, label="start")
    ax.plot(*scene.goal, "k*", markersize=8, label="goal")


def scene_extent(
    scene: Scene, paths: Sequence[Path2D] = (), margin: float = 1.0
) -> tuple[float, float, float, float]:
    """xmin, xmax, ymin, ymax holding every obstacle, the start, the goal and the paths,
    plus ``margin`` m (flies far outside the scene do not stretch the map)."""
    fp = scene.footprints
    r = fp.bounding_radius()
    start = scene.start_pose
    xs = [*(fp.cx - r), *(fp.cx + r), start.x, scene.goal[0]]
    ys = [*(fp.cy - r), *(fp.cy + r), start.y, scene.goal[1]]
    for p in paths:
        xs += [float(p.xy[:, 0].min()), float(p.xy[:, 0].max())] if len(p.xy) else []
        ys += [float(p.xy[:, 1].min()), float(p.xy[:, 1].max())] if len(p.xy) else []
    return min(xs) - margin, max(xs) + margin, min(ys) - margin, max(ys) + margin


def _draw_view(ax: Any, pose: tuple[float, float, float], half_fov: float, reach: float) -> None:
    x, y, theta = pose
    for side in (-1.0, 1.0):
        a = theta + side * half_fov
        ax.plot([x, x + reach * math.cos(a)], [y, y + reach * math.sin(a)], "r-", linewidth=1.0)


def map_figure(
    path: Path,
    scene: Scene,
    panels: Sequence[MapPanel],
    *,
    rig: StereoRig | None = None,
    title: str | None = None,
    width: float | None = None,
) -> Path:
    """Top-down panels side by side (x forward at the start, y left), equal axes.
    ``width`` (inches): one panel that wide, its height following its extent's aspect, the
    legend outside the axes (beside them) so it hides nothing."""
    plt = pyplot()
    n = len(panels)
    if width is None:
        fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 4.4), squeeze=False)
    else:
        xmin, xmax, ymin, ymax = panels[0].extent or scene_extent(scene, panels[0].paths)
        height = min(max(width * (ymax - ymin) / (xmax - xmin), 2.5), 1.2 * width)
        fig, axes = plt.subplots(1, n, figsize=(width, height + 0.8), squeeze=False)
    for ax, panel in zip(axes[0], panels, strict=True):
        draw_scene(ax, scene)
        for p in panel.paths:
            ax.plot(p.xy[:, 0], p.xy[:, 1], p.style, color=p.colour, lw=p.width, label=p.label)
        if panel.flies is not None and len(panel.flies):
            ax.scatter(
                panel.flies[:, 0],
                panel.flies[:, 1],
                s=4,
                c="tab:purple",
                alpha=0.6,
                label=panel.flies_label,
                linewidths=0,
                zorder=5,
            )
        if panel.view_from is not None and rig is not None:
            _draw_view(ax, panel.view_from, rig.half_fov, 8.0)
        xmin, xmax, ymin, ymax = panel.extent or scene_extent(scene, panel.paths)
        ax.set_xlim(xmin, xmax)
        ax.set_ylim(ymin, ymax)
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title(panel.title, fontsize=10)
        ax.grid(True, linewidth=0.3)
        handles, labels = ax.get_legend_handles_labels()
        unique = dict(zip(labels, handles, strict=True))
        if width is None:
            ax.legend(unique.values(), unique.keys(), fontsize=7, loc="best")
        else:
            ax.legend(
                unique.values(),
                unique.keys(),
                fontsize=8,
                loc="upper left",
                bbox_to_anchor=(1.01, 1.0),
                borderaxespad=0.0,
            )
    if title:
        fig.suptitle(title, fontsize=11)
    return save_figure(fig, path)


@dataclass(frozen=True)
class FramePanel:
    """A left image with flies drawn at their left projections ``uv`` (M, 2) pixels, and
    optionally a value per fly (``values``, e.g. its fitness) that colours it."""

    title: str
    image: np.ndarray
    uv: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    values: np.ndarray | None = None


def frames_figure(
    path: Path,
    panels: Sequence[FramePanel],
    *,
    columns: int = 2,
    size: float = 3.6,
    value_label: str = "",
) -> Path:
    """Left frames in a grid with the flies as red dots (paper Fig. 4/5, 9); ``size``:
    each frame's width (inches). Panels with ``values`` colour their flies by them, on
    one scale (the 2nd to 98th percentile of all of them) with a colour bar ``value_label``."""
    plt = pyplot()
    rows = math.ceil(len(panels) / columns)
    h, w = panels[0].image.shape[:2]
    valued = [p.values for p in panels if p.values is not None and len(p.values)]
    lo, hi = np.percentile(np.concatenate(valued), [2, 98]) if valued else (0.0, 1.0)
    fig, axes = plt.subplots(
        rows, columns, figsize=(size * columns, size * h / w * rows + 0.4 * rows), squeeze=False
    )
    for ax in axes.ravel():
        ax.axis("off")
    dots = None
    for ax, panel in zip(axes.ravel(), panels, strict=False):
        ax.imshow(panel.image, interpolation="nearest")
        if len(panel.uv) and panel.values is not None:
            dots = ax.scatter(
                panel.uv[:, 0],
                panel.uv[:, 1],
                s=9,
                c=panel.values,
                cmap="plasma",
                vmin=lo,
                vmax=hi,
                linewidths=0,
            )
        elif len(panel.uv):
            ax.scatter(panel.uv[:, 0], panel.uv[:, 1], s=6, c="red", linewidths=0)
        ax.set_xlim(-0.5, w - 0.5)
        ax.set_ylim(h - 0.5, -0.5)
        ax.set_title(panel.title, fontsize=9)
    if dots is not None:
        fig.colorbar(dots, ax=axes.ravel().tolist(), fraction=0.02, pad=0.01, label=value_label)
    return save_figure(fig, path)


@dataclass(frozen=True)
class Curve:
    """One configuration's metric over time: a (t, y) pair per seed."""

    label: str
    runs: tuple[tuple[np.ndarray, np.ndarray], ...]


def curves_figure(
    path: Path,
    panels: Sequence[tuple[str, Sequence[Curve]]],
    *,
    xlabel: str = "time (s)",
    title: str | None = None,
    ylims: Sequence[tuple[float | None, float | None]] | None = None,
) -> Path:
    """Panels of curves (one per ylabel): each seed thin, the mean over seeds bold (over the
    times all seeds share). ``ylims``: each panel's (bottom, top), None for matplotlib's."""
    plt = pyplot()
    fig, axes = plt.subplots(1, len(panels), figsize=(4.6 * len(panels), 3.4), squeeze=False)
    for i, (ax, (ylabel, curves)) in enumerate(zip(axes[0], panels, strict=True)):
        for colour, curve in zip(COLOURS, curves, strict=False):
            for t, y in curve.runs:
                ax.plot(t, y, color=colour, lw=0.6, alpha=0.35)
            n = min((len(t) for t, _ in curve.runs), default=0)
            if n:
                with warnings.catch_warnings():  # an all-NaN instant (nothing in view)
                    warnings.simplefilter("ignore", RuntimeWarning)
                    mean = np.nanmean(np.stack([y[:n] for _, y in curve.runs]), axis=0)
                ax.plot(curve.runs[0][0][:n], mean, color=colour, lw=2.0, label=curve.label)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.grid(True, linewidth=0.3)
        ax.legend(fontsize=8)
        if ylims is not None:
            bottom, top = ylims[i]
            ax.set_ylim(bottom=bottom, top=top)
    if title:
        fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    return save_figure(fig, path)


def bars_figure(
    path: Path, labels: Sequence[str], values: Sequence[Sequence[float]], ylabel: str, title: str
) -> Path:
    """One box of per-run values per configuration (e.g. latencies of every obstacle)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(1.6 * len(labels) + 2.0, 3.4))
    data = [np.asarray(v, dtype=float)[np.isfinite(v)] for v in values]
    ax.boxplot(data, showmeans=True)
    ax.set_xticks(range(1, len(labels) + 1), labels)
    for i, v in enumerate(data, start=1):
        jitter = np.linspace(-0.12, 0.12, len(v)) if len(v) > 1 else np.zeros(len(v))
        ax.scatter(i + jitter, v, s=8, alpha=0.6, color="tab:blue", linewidths=0)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(True, axis="y", linewidth=0.3)
    fig.tight_layout()
    return save_figure(fig, path)
