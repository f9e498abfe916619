"""``flylog report RUN.mcap --log LOG.mcap``: one run on one page: its metrics summary, a
top-down map (obstacles, the true and odometric trajectories, the obstacle flies of every
snapshot placed by the true pose), left frames with the obstacle flies drawn at a few
moments, curves over time (precision, recall, obstacle flies, image latency) and the
run's configuration. The figures are ``flylog.experiments.plots``'."""

from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from flylog.errors import LogError
from flylog.io.inputs import input_path
from flylog.report.html import Page, write_page

# Left frames shown, evenly spread over the run's snapshots, each this wide (inches at the
# figures' 80 dpi: 560 px, two a row), and the map's width.
FRAMES = 4
FRAME_WIDTH_IN = 7.0
MAP_WIDTH_IN = 13.0
# The map holds the obstacles this close to the true trajectory (the cameras' useful range)
# and spans at least this much each way.
OBSTACLE_REACH_M = 4.0
MIN_SPAN_M = 4.0
# Summary columns that identify what was scored rather than score it: in the folded section.
PROVENANCE = ("log_fingerprint", "run_config", "metrics_config")
# At most this many obstacle flies on the map (every k-th of all snapshots'): the map
# stays readable and its PNG small.
MAP_FLIES = 6000


def _summary_rows(summary: dict[str, Any]) -> list[tuple[str, Any, str, str]]:
    """The summary's columns that hold a value for this run (a dataset run has no path, a
    replay no time to goal): the others would be rows of "—"."""
    from flylog.metrics.tables import SUMMARY_COLUMNS

    return [
        (c.name, summary.get(c.name), c.unit, c.description)
        for c in SUMMARY_COLUMNS
        if c.name not in ("run", "log", *PROVENANCE) and _known(summary.get(c.name))
    ]


def _known(value: Any) -> bool:
    return value is not None and not (isinstance(value, float) and math.isnan(value))


def _run_config(run: Path) -> dict[str, Any]:
    from flylog.io import contract, open_log

    meta = open_log(run).metadata().get(contract.REPLAY_METADATA, {})
    try:
        config = json.loads(meta.get("config", "{}"))
    except json.JSONDecodeError:
        return {}
    return config if isinstance(config, dict) else {}


def engine_text(config: dict[str, Any]) -> str:
    """What ran, in words, from a run's configuration."""
    if config.get("stereo") == "sgbm":
        return "SGBM (conventional stereo, whole frames, frame-synchronous)"
    flies = config.get("engine", {}).get("flies", "?")
    gens = config.get("generations_per_frame", 0)
    mode = (
        "frame-synchronous"
        if config.get("sync")
        else "asynchronous"
        if not gens
        else f"{gens} generation{'s' if gens != 1 else ''} per frame"
    )
    return f"The fly engine ({flies} flies, {mode})"


def _f(x: Any, spec: str = ".2f", unit: str = "") -> str:
    return f"{x:{spec}}{unit}" if _known(x) else "—"


def scene_headline(summary: dict[str, Any], closed_loop: bool, sgbm: bool) -> tuple[str, str]:
    """The verdict in a sentence and the key figures of a run on a simulated log."""
    points = "SGBM's points" if sgbm else "The obstacle flies"
    seen, found = summary.get("obstacles_visible"), summary.get("obstacles_detected")
    verdict = f"{points} reach F {_f(summary.get('f_score'))}"
    if _known(seen) and seen:
        verdict += f" and detect {found} of the {seen} obstacles in view"
    if closed_loop:
        collisions = summary.get("collisions") or 0
        crash = "without collision" if not collisions else f"with {collisions} collision(s)"
        if summary.get("goal_reached"):
            took = _f(summary.get("time_to_goal_s"), ".1f", " s")
            verdict += f"; the robot reaches the goal in {took} {crash}"
        else:
            verdict += (
                f"; the robot stops {_f(summary.get('final_goal_distance_m'), '.2f', ' m')} "
                f"short of the goal, {crash}"
            )
    figures = [
        f"precision {_f(summary.get('precision'))}",
        f"recall {_f(summary.get('recall'))}",
        f"median relative depth error {_f(summary.get('median_depth_error'), '.1%')}",
        f"detection latency {_f(summary.get('detection_latency_mean_s'), '.2f', ' s')} (mean)",
    ]
    if closed_loop:
        figures += [
            f"minimum clearance {_f(summary.get('min_clearance_m'), '.2f', ' m')}",
            f"odometry ATE {_f(summary.get('ate_m'), '.3f', ' m')}",
        ]
    figures.append(f"{summary.get('snapshots') or 0} snapshots")
    return verdict + ".", " · ".join(figures)


def _snapshots(run: Path) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray]]:
    """Times (ns), obstacle flies (M, 3, base_link) and their fitness of every snapshot, by
    the run's own obstacle rule."""
    from flylog.io import contract, open_log
    from flylog.metrics.config import MetricsConfig
    from flylog.metrics.score import run_facts

    reader = open_log(run)
    rule = run_facts(reader, MetricsConfig()).rule
    times, clouds, fitness = [], [], []
    for m in reader.messages([contract.FLIES]):
        cloud = m.value
        keep = rule.mask(cloud.xyz, cloud.fitness, cloud.age, cloud.distinct)
        times.append(m.log_time_ns)
        clouds.append(np.asarray(cloud.xyz[keep], dtype=np.float64).reshape(-1, 3))
        fitness.append(np.asarray(cloud.fitness[keep], dtype=np.float64))
    return np.array(times, dtype=np.int64), clouds, fitness


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


def _frame_panels(
    log: Path,
    rig: Any,
    times: np.ndarray,
    clouds: list[np.ndarray],
    fitness: list[np.ndarray],
    points: str,
) -> list:
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
        uv, values = np.empty((0, 2)), np.empty(0)
        if len(xyz):
            u, _, v, _ = rig.project(xyz)
            ok = (u >= 0) & (u < rig.width) & (v >= 0) & (v < rig.height)
            uv, values = np.stack([u[ok], v[ok]], axis=1), fitness[i][ok]
        title = f"t = {(stamp - t0) / 1e9:.2f} s, {len(uv)} {points} in view"
        panels.append(FramePanel(title, image, uv, values))
    return panels


def _curves(
    snapshots: list[dict[str, Any]], steps: Path, t0_s: float, points: str
) -> tuple[list, list, list[str]]:
    """Curve panels, their y limits and notes for the curves left out: a curve that holds
    one value throughout is a sentence, not a plot. Shares run from 0 to 1 and counts and
    times from 0, so that a small change does not fill the axis."""
    from flylog.experiments.plots import Curve

    t = np.array([r["t_s"] for r in snapshots], dtype=float)

    def column(name: str) -> np.ndarray:
        return np.array([np.nan if r[name] is None else r[name] for r in snapshots], dtype=float)

    series = [
        ("precision", t, column("precision"), (0.0, 1.02)),
        ("recall", t, column("recall"), (0.0, 1.02)),
        (points, t, column("obstacle_flies"), (0.0, None)),
    ]
    if steps.is_file():  # a replay's per-step table (a closed-loop log has none)
        import pyarrow.parquet as pq

        table = pq.read_table(
            input_path(steps, "the step table"), columns=["t_s", "image_latency_s"]
        ).to_pydict()
        st = np.array(table["t_s"], dtype=float)
        lat = np.array([np.nan if v is None else v for v in table["image_latency_s"]], dtype=float)
        series.append(("image latency (s)", st - t0_s, lat, (0.0, None)))
    panels, ylims, notes = [], [], []
    for label, x, y, ylim in series:
        finite = y[np.isfinite(y)]
        if not len(finite):
            notes.append(f"{label}: no value in this run")
        elif np.ptp(finite) == 0:
            notes.append(f"{label}: {finite[0]:.4g} throughout")
        else:
            panels.append((label, [Curve("run", ((x, y),))]))
            ylims.append(ylim)
    return panels, ylims, notes


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
    ``flylog metrics -o`` output of that run). A run on an imported dataset's log is drawn
    against its ground-truth disparity (flylog.report.dataset)."""
    from flylog.metrics.image_run import has_image_truth

    run, log = Path(run), Path(log if log is not None else run)
    if Path(output).resolve() in (run.resolve(), log.resolve()):
        msg = f"report would overwrite its input {output}: choose another -o"
        raise LogError(msg)
    summary, snapshots = _metrics(run, log, metrics)
    config = _run_config(run)
    sgbm = config.get("stereo") == "sgbm"
    page = Page(f"flylog run {run.name}")
    with tempfile.TemporaryDirectory(prefix="flylog-report-") as tmp:
        if has_image_truth(log):
            _dataset_page(page, run, log, summary, config, Path(tmp), sgbm)
        else:
            _scene_page(page, run, log, summary, snapshots, config, Path(tmp), sgbm)
    page.heading("Configuration")
    if not config:
        page.note("The run carries no flylog configuration.")
    else:
        page.folded(
            "The run's effective configuration (its flylog.replay metadata record): unfold",
            json.dumps(config, indent=2),
        )
    ids = [f"{k}: {summary[k]}" for k in PROVENANCE if _known(summary.get(k))]
    if ids:
        page.folded("What was scored (fingerprints and digests): unfold", "\n".join(ids))
    return write_page(page, output)


def _summary_table(page: Page, summary: dict[str, Any]) -> None:
    page.heading("Summary")
    page.table(["metric", "value", "unit", "meaning"], _summary_rows(summary), text_columns=1)


def _dataset_page(
    page: Page,
    run: Path,
    log: Path,
    summary: dict[str, Any],
    config: dict[str, Any],
    here: Path,
    sgbm: bool,
) -> None:
    from flylog.io import contract, open_log
    from flylog.report.dataset import POINTS_FLIES, POINTS_SGBM, dataset_sections, headline

    dataset = open_log(log).metadata().get(contract.DATASET_METADATA, {})
    name = " ".join(str(dataset.get(k, "")) for k in ("layout", "sequence") if dataset.get(k))
    on = f"{log.name}" + (f" ({name})" if name else "") + ", an imported dataset's log"
    verdict, figures = headline(summary, POINTS_SGBM if sgbm else POINTS_FLIES, log.name)
    page.headline(f"{engine_text(config)}, replayed on {on}.", verdict, figures)
    _summary_table(page, summary)
    dataset_sections(page, run, log, summary, here, sgbm)


def _scene_page(
    page: Page,
    run: Path,
    log: Path,
    summary: dict[str, Any],
    snapshots: list[dict[str, Any]],
    config: dict[str, Any],
    here: Path,
    sgbm: bool,
) -> None:
    from flylog.experiments import plots
    from flylog.experiments.runs import trajectories
    from flylog.metrics.truth import read_truth
    from flylog.replay.run import table_path

    truth = read_truth(log)
    _, true_xyt, odom_xyt = trajectories(log)
    times, clouds, fitness = _snapshots(run)
    closed = run.resolve() == log.resolve()
    rig = truth.rig
    seconds = (truth.true.t_ns[-1] - truth.true.t_ns[0]) / 1e9 if len(truth.true.t_ns) else 0.0
    about = f"scene {truth.scene.name}, {seconds:.1f} s, {rig.width}×{rig.height} px"
    what = (
        f"A closed loop: {engine_text(config)} and the planner drive the robot ({about})."
        if closed
        else f"{engine_text(config)}, replayed on {log.name} ({about})."
    )
    page.headline(what, *scene_headline(summary, closed, sgbm))
    _summary_table(page, summary)
    points = "SGBM points" if sgbm else "obstacle flies"  # as flylog.report.dataset's
    paths = (
        plots.Path2D(true_xyt[:, :2], "true trajectory", "tab:green"),
        plots.Path2D(odom_xyt[:, :2], "odometric trajectory", "tab:orange", "--"),
    )
    world = _world_flies(log, times, clouds)
    panel = plots.MapPanel(
        "top-down",
        paths,
        flies=world,
        flies_label=points,
        extent=_map_extent(truth.scene, world, true_xyt, odom_xyt),
    )
    page.heading("Map")
    page.figure(
        plots.map_figure(here / "map.png", truth.scene, [panel], rig=rig, width=MAP_WIDTH_IN),
        "Obstacles (hatched: low texture; dashed: sonar-absorbing), the true and odometric "
        f"trajectories, and the {points} of every snapshot placed in the world by the true "
        "pose at its time; the map spans the trajectories, the start, the goal, the obstacles "
        "near the path and the bulk of the points.",
    )
    # SGBM's cloud carries a texture score in its fitness field (1 + the mean gradient
    # around the pixel, flylog.baseline.sgbm): named as what it is.
    score = "texture score" if sgbm else "fitness"
    frames = _frame_panels(log, rig, times, clouds, fitness, points)
    if frames:
        page.heading("Left frames")
        page.figure(
            plots.frames_figure(
                here / "frames.png", frames, size=FRAME_WIDTH_IN, value_label=score
            ),
            f"Left images at snapshots spread over the run, the {points} of the snapshot "
            f"drawn at their projections, coloured by their {score} (one scale for all).",
        )
    else:
        page.note("The run holds no fly snapshot: no frame is drawn.")
    if snapshots:
        t0_s = float(truth.true.t_ns[0]) / 1e9
        curves, ylims, notes = _curves(snapshots, table_path(run), t0_s, points)
        page.heading("Over time")
        if curves:
            ticks = any(label.startswith("image latency") for label, _ in curves)
            page.figure(
                plots.curves_figure(here / "curves.png", curves, ylims=ylims),
                f"Per snapshot: precision and recall of the {points}, their number"
                + (
                    "; per planner tick: the age of the images they were scored on."
                    if ticks
                    else "."
                ),
            )
        for note in notes:
            page.note(f"Not drawn, constant or empty: {note}.")


def _map_extent(
    scene: Any, world_flies: np.ndarray, *trajectories: np.ndarray, margin: float = 1.0
) -> tuple[float, float, float, float]:
    """xmin, xmax, ymin, ymax around the trajectories, the start, the goal, the obstacles
    within OBSTACLE_REACH_M of the true trajectory and the bulk of the flies (2nd to 98th
    percentile): what the run saw and did, not the whole world (a corridor's walls run on
    far beyond its path, cut at the frame). At least MIN_SPAN_M a side."""
    start = scene.start_pose
    xs = [start.x, scene.goal[0]] + [
        v for t in trajectories for v in (t[:, 0].min(), t[:, 0].max())
    ]
    ys = [start.y, scene.goal[1]] + [
        v for t in trajectories for v in (t[:, 1].min(), t[:, 1].max())
    ]
    fp = scene.footprints
    path = trajectories[0][:, :2]
    for cx, cy, r in zip(fp.cx, fp.cy, fp.bounding_radius(), strict=True):
        if np.hypot(path[:, 0] - cx, path[:, 1] - cy).min() - r <= OBSTACLE_REACH_M:
            xs += [min(max(cx, min(xs) - OBSTACLE_REACH_M), max(xs) + OBSTACLE_REACH_M)]
            ys += [min(max(cy, min(ys) - OBSTACLE_REACH_M), max(ys) + OBSTACLE_REACH_M)]
    if len(world_flies):
        lo, hi = np.percentile(world_flies, [2, 98], axis=0)
        xs += [float(lo[0]), float(hi[0])]
        ys += [float(lo[1]), float(hi[1])]
    x0, x1, y0, y1 = min(xs) - margin, max(xs) + margin, min(ys) - margin, max(ys) + margin
    grow_x, grow_y = max(0.0, MIN_SPAN_M - (x1 - x0)) / 2, max(0.0, MIN_SPAN_M - (y1 - y0)) / 2
    return x0 - grow_x, x1 + grow_x, y0 - grow_y, y1 + grow_y
