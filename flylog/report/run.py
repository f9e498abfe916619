"""``flylog report RUN.mcap --log LOG.mcap``: one run on one page: its metrics summary, a
top-down map (obstacles, the true and odometric trajectories, the obstacle flies of every
snapshot placed by the true pose), left frames with the obstacle flies drawn at a few
moments, curves over time (precision, recall, obstacle flies, image latency) and the
run's configuration. The figures are ``flylog.experiments.plots``'."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from flylog.errors import LogError
from flylog.io.inputs import input_path
from flylog.report.html import Page, write_page

# Left frames shown, evenly spread over the run's snapshots.
FRAMES = 4
# At most this many obstacle flies on the map (every k-th of all snapshots'): the map
# stays readable and its PNG small.
MAP_FLIES = 6000


def _summary_rows(summary: dict[str, Any]) -> list[tuple[str, Any, str, str]]:
    from flylog.metrics.tables import SUMMARY_COLUMNS

    return [(c.name, summary.get(c.name), c.unit, c.description) for c in SUMMARY_COLUMNS]


def _configuration(run: Path) -> str | None:
    from flylog.io import contract, open_log

    meta = open_log(run).metadata().get(contract.REPLAY_METADATA, {})
    if "config" not in meta:
        return None
    try:
        return json.dumps(json.loads(meta["config"]), indent=2)
    except json.JSONDecodeError:
        return meta["config"]


def _world_flies(log: Path, times: np.ndarray, clouds: list[np.ndarray]) -> np.ndarray:
    from flylog.experiments.runs import to_world, true_poses_at

    if not len(times):
        return np.empty((0, 2))
    poses = true_poses_at(log, times)
    points = [to_world(c, p) for c, p in zip(clouds, poses, strict=True) if len(c)]
    if not points:
        return np.empty((0, 2))
    xy = np.concatenate(points)
    step = max(1, len(xy) // MAP_FLIES)
    return xy[::step]


def _frame_panels(log: Path, rig: Any, times: np.ndarray, clouds: list[np.ndarray]) -> list:
    from flylog.experiments.plots import FramePanel
    from flylog.experiments.runs import left_image_at

    if not len(times):
        return []
    picks = sorted({int(i) for i in np.linspace(0, len(times) - 1, FRAMES).round()})
    t0 = times[0]
    panels = []
    for i in picks:
        stamp, image = left_image_at(log, int(times[i]))
        xyz = clouds[i]
        uv = np.empty((0, 2))
        if len(xyz):
            u, _, v, _ = rig.project(xyz)
            ok = (u >= 0) & (u < rig.width) & (v >= 0) & (v < rig.height)
            uv = np.stack([u[ok], v[ok]], axis=1)
        title = f"t = {(stamp - t0) / 1e9:.2f} s, {len(uv)} obstacle flies in view"
        panels.append(FramePanel(title, image, uv))
    return panels


def _curves(snapshots: list[dict[str, Any]], steps: Path, t0_s: float) -> list:
    """Curve panels; ``t0_s``: log time of the first true pose (the snapshots' origin)."""
    from flylog.experiments.plots import Curve

    t = np.array([r["t_s"] for r in snapshots], dtype=float)

    def column(name: str) -> np.ndarray:
        return np.array([np.nan if r[name] is None else r[name] for r in snapshots], dtype=float)

    panels = [
        ("precision", [Curve("run", ((t, column("precision")),))]),
        ("recall", [Curve("run", ((t, column("recall")),))]),
        ("obstacle flies", [Curve("run", ((t, column("obstacle_flies")),))]),
    ]
    if steps.is_file():  # a replay's per-step table (a closed-loop log has none)
        import pyarrow.parquet as pq

        table = pq.read_table(
            input_path(steps, "the step table"), columns=["t", "image_latency"]
        ).to_pydict()
        st = np.array(table["t"], dtype=float)
        lat = np.array([np.nan if v is None else v for v in table["image_latency"]], dtype=float)
        panels.append(("image latency (s)", [Curve("run", ((st - t0_s, lat),))]))
    return panels


def _metrics(run: Path, log: Path, metrics: Path | None) -> tuple[dict, list[dict]]:
    """(summary, snapshot rows): read from a `flylog metrics -o` output, else scored now."""
    if metrics is None:
        from flylog.metrics.config import MetricsConfig
        from flylog.metrics.score import score_run

        result = score_run(run, log, MetricsConfig())
        return result.summary, result.snapshots
    import pyarrow as pa
    import pyarrow.parquet as pq

    from flylog.metrics.tables import read_summary

    summary = read_summary(metrics)
    try:
        snapshots = pq.read_table(input_path(metrics, "the metrics table")).to_pylist()
    except (pa.ArrowInvalid, OSError) as exc:
        msg = f"{metrics}: not a readable metrics table ({exc})"
        raise LogError(msg) from None
    return summary, snapshots


def run_report(run: Path, log: Path | None, output: Path, *, metrics: Path | None = None) -> Path:
    """Write the page of ``run`` (a replay's output, or a closed-loop log: then it is its own
    ``log``) scored against the truth of ``log``, or with the tables of ``metrics`` (a
    ``flylog metrics -o`` output of that run)."""
    from flylog.experiments import plots
    from flylog.experiments.runs import fly_snapshots, trajectories
    from flylog.metrics.truth import read_truth
    from flylog.replay.run import table_path

    run, log = Path(run), Path(log if log is not None else run)
    if Path(output).resolve() in (run.resolve(), log.resolve()):
        msg = f"report would overwrite its input {output}: choose another -o"
        raise LogError(msg)
    summary, snapshots = _metrics(run, log, metrics)
    truth = read_truth(log)
    _, true_xyt, odom_xyt = trajectories(log)
    times, clouds = fly_snapshots(run)
    page = Page(f"flylog run {run.name}")
    page.note(f"run {run}, scored against the truth of {log}")
    page.heading("Summary")
    page.table(["metric", "value", "unit", "meaning"], _summary_rows(summary),
               text_columns=1)  # fmt: skip
    with tempfile.TemporaryDirectory(prefix="flylog-report-") as tmp:
        here = Path(tmp)
        paths = (
            plots.Path2D(true_xyt[:, :2], "true trajectory", "tab:green"),
            plots.Path2D(odom_xyt[:, :2], "odometric trajectory", "tab:orange", "--"),
        )
        panel = plots.MapPanel("top-down", paths, flies=_world_flies(log, times, clouds))
        page.heading("Map")
        page.figure(
            plots.map_figure(here / "map.png", truth.scene, [panel], rig=truth.rig),
            "Obstacles (hatched: low texture; dashed: sonar-absorbing), the true and "
            "odometric trajectories, and the obstacle flies of every snapshot placed in the "
            "world by the true pose at its time.",
        )
        frames = _frame_panels(log, truth.rig, times, clouds)
        if frames:
            page.heading("Left frames")
            page.figure(
                plots.frames_figure(here / "frames.png", frames),
                "Left images at snapshots spread over the run, the obstacle flies of the "
                "snapshot drawn at their projections (red).",
            )
        else:
            page.note("The run holds no fly snapshot: no frame is drawn.")
        if snapshots:
            t0_s = float(truth.true.t_ns[0]) / 1e9
            curves = _curves(snapshots, table_path(run), t0_s)
            page.heading("Over time")
            page.figure(
                plots.curves_figure(here / "curves.png", curves),
                "Per snapshot: precision and recall of the obstacle flies, their number; per "
                "planner tick: the age of the images the flies were scored on.",
            )
    config = _configuration(run)
    page.heading("Configuration")
    if config is None:
        page.note("The run carries no flylog configuration.")
    else:
        page.preformatted(config)
    return write_page(page, output)
