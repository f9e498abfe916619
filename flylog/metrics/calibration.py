"""Calibration of the flies' confidence (:mod:`flylog.fly.confidence`) against ground truth:
each valid fly of a run's snapshots that the truth can judge, labelled on a surface or not
(the metrics' definition: ``|d − D| ≤ τ·D`` at its rounded left projection), its features,
the fit of a model, and the expected calibration error (ECE) with its reliability table.

Simulated logs are judged against the rendered true view (:mod:`flylog.metrics.view`), as
the fly metrics are; an imported dataset's log against its ground-truth disparity or depth
images (:mod:`flylog.metrics.image_truth`).
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from flylog.errors import LogError
from flylog.fly import confidence as cf
from flylog.io import contract, open_log
from flylog.io.reader import LogReader
from flylog.metrics.config import MetricsConfig
from flylog.metrics.provenance import config_digest
from flylog.metrics.true_depth import views_at

BINS = 10  # equal-width confidence bins of the ECE and the reliability table
_BATCH = 32  # snapshots whose true views render together


class Labelled(NamedTuple):
    """The judged flies of some snapshots: features
    (:data:`flylog.fly.confidence.BASE_FEATURES`, each (N,)), whether each lies on a surface,
    the index of its snapshot and whether the run's obstacle rule takes it."""

    features: dict[str, np.ndarray]
    on_surface: np.ndarray
    snapshot: np.ndarray
    obstacle: np.ndarray  # taken for an obstacle by the run's rule

    @property
    def flies(self) -> int:
        return len(self.on_surface)


def concatenate(parts: Sequence[Labelled]) -> Labelled:
    if not parts:
        none = np.empty(0, bool)
        return Labelled({n: np.empty(0) for n in cf.BASE_FEATURES}, none, np.empty(0, int), none)
    offsets = np.cumsum([0] + [int(p.snapshot.max()) + 1 if p.flies else 0 for p in parts])
    return Labelled(
        {n: np.concatenate([p.features[n] for p in parts]) for n in cf.BASE_FEATURES},
        np.concatenate([p.on_surface for p in parts]),
        np.concatenate([p.snapshot + o for p, o in zip(parts, offsets, strict=False)]),
        np.concatenate([p.obstacle for p in parts]),
    )


def engine_digest(run: LogReader) -> str:
    """Digest of the ``engine`` and ``obstacles`` sections of the configuration a run was
    replayed with (what a confidence model holds for); "" when it records none."""
    text = run.metadata().get(contract.REPLAY_METADATA, {}).get("config")
    if text is None:
        return ""
    config = json.loads(text)
    return config_digest({k: config.get(k) for k in ("engine", "obstacles")})


def default_engine_digest() -> str:
    """:func:`engine_digest` of flylog's default replay configuration."""
    from flylog.config import to_mapping
    from flylog.replay.config import ReplayConfig

    config = to_mapping(ReplayConfig())
    return config_digest({k: config.get(k) for k in ("engine", "obstacles")})


def labelled_run(run: str | Path, log: str | Path, config: MetricsConfig) -> Labelled:
    """Every valid fly of ``run``'s snapshots that ``log``'s truth judges, labelled."""
    from flylog.metrics.image_run import has_image_truth

    reader = open_log(run)
    if contract.FLIES not in reader.topics():
        msg = f"{run} has no {contract.FLIES} topic: nothing to calibrate on"
        raise LogError(msg)
    if has_image_truth(log):
        return _labelled_images(reader, Path(log), config)
    return _labelled_scene(reader, Path(log), config)


def _rule(reader: LogReader, config: MetricsConfig) -> Any:
    from flylog.metrics.score import run_facts

    return run_facts(reader, config).rule


def _judged(
    xyz: np.ndarray, fitness: np.ndarray, rig: Any
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The valid flies in the left view: (their indices, rounded u, rounded v, depth)."""
    u, _, v, d = rig.project(np.asarray(xyz, dtype=np.float64))
    iu, iv = np.rint(u), np.rint(v)
    ok = (fitness > 0) & (d > 0) & (iu >= 0) & (iu < rig.width) & (iv >= 0) & (iv < rig.height)
    return np.flatnonzero(ok), iu[ok].astype(np.int64), iv[ok].astype(np.int64), d[ok]


def _labelled_scene(reader: LogReader, log: Path, config: MetricsConfig) -> Labelled:
    from flylog.metrics.trajectory import PoseInterpolator
    from flylog.metrics.truth import read_truth
    from flylog.metrics.view import TrueViews

    truth = read_truth(log)
    rule = _rule(reader, config)
    views = TrueViews(truth.scene, truth.rig, config.truth_width)
    pose_at = PoseInterpolator(truth.true)
    parts: list[Labelled] = []
    batch: list[tuple[int, Any]] = []

    def flush() -> None:
        depth, ids = views.render(pose_at(np.array([t for t, _ in batch])))
        judged = [_judged(cloud.xyz, cloud.fitness, truth.rig) for _, cloud in batch]
        s = np.repeat(np.arange(len(batch)), [len(j[0]) for j in judged])
        iu, iv, d = (np.concatenate([j[i] for j in judged]) for i in (1, 2, 3))
        # the batch's flies together: one call, each against its snapshot's view
        true_d, _ = views_at(depth, ids, s, iu, iv, d, config.tau, views.block)
        seen = np.isfinite(true_d)  # the sky judges a fly off every surface, as precision does
        on = np.zeros(len(d), dtype=bool)
        on[seen] = np.abs(d[seen] - true_d[seen]) <= config.tau * true_d[seen]
        bounds = np.searchsorted(s, np.arange(len(batch) + 1))
        for k, (_, cloud) in enumerate(batch):
            idx = judged[k][0]
            table = cf.features(cloud.fitness, cloud.age, cloud.distinct)
            keep = rule.mask(cloud.xyz, cloud.fitness, cloud.age, cloud.distinct)[idx]
            features = {n: v[idx] for n, v in table.items()}
            labels = on[bounds[k] : bounds[k + 1]]
            parts.append(Labelled(features, labels, np.full(len(idx), len(parts)), keep))
        batch.clear()

    for m in reader.messages([contract.FLIES]):
        batch.append((m.log_time_ns, m.value))
        if len(batch) == _BATCH:
            flush()
    if batch:
        flush()
    return concatenate(parts)


def _labelled_images(reader: LogReader, log: Path, config: MetricsConfig) -> Labelled:
    from flylog.metrics.image_truth import read_disparity_truth, truth_at
    from flylog.replay.inputs import log_rig

    sensor = open_log(log)
    dataset = sensor.metadata().get(contract.DATASET_METADATA, {})
    rig = log_rig(sensor, mounted=dataset.get("mount") != contract.MOUNT_NONE)
    truth = read_disparity_truth(sensor, rig)
    # no ground plane under a dataset's cameras: the rule's ground test is off, as metrics has it
    rule = dataclasses.replace(_rule(reader, config), ground_margin=-math.inf)
    parts: list[Labelled] = []
    for m in reader.messages([contract.FLIES]):
        k = truth.at(m.log_time_ns)
        if k is None:
            continue
        cloud = m.value
        idx, iu, iv, d = _judged(cloud.xyz, cloud.fitness, rig)
        true = truth_at(truth.images[k], iu.astype(float), iv.astype(float))
        known = np.isfinite(true)
        true_depth = rig.depth_of_disparity(true[known])
        on = np.abs(d[known] - true_depth) <= config.tau * true_depth
        table = cf.features(cloud.fitness, cloud.age, cloud.distinct)
        keep = rule.mask(cloud.xyz, cloud.fitness, cloud.age, cloud.distinct)[idx][known]
        features = {n: v[idx][known] for n, v in table.items()}
        parts.append(Labelled(features, on, np.full(len(on), len(parts)), keep))
    return concatenate(parts)


# ---- scores ------------------------------------------------------------------------------


def reliability(p: np.ndarray, y: np.ndarray, bins: int = BINS) -> list[dict[str, Any]]:
    """The reliability diagram's table: for each of ``bins`` equal-width confidence bins, its
    bounds, fly count, mean confidence and share of flies on a surface (NaN when empty)."""
    p, y = np.asarray(p, dtype=np.float64), np.asarray(y, dtype=np.float64)
    which = np.minimum((p * bins).astype(np.int64), bins - 1)
    count = np.bincount(which, minlength=bins)
    sum_p = np.bincount(which, weights=p, minlength=bins)
    sum_y = np.bincount(which, weights=y, minlength=bins)
    rows = []
    for b in range(bins):
        n = int(count[b])
        rows.append(
            {
                "bin_low": b / bins,
                "bin_high": (b + 1) / bins,
                "flies": n,
                "mean_confidence": sum_p[b] / n if n else math.nan,
                "on_surface_share": sum_y[b] / n if n else math.nan,
            }
        )
    return rows


def expected_calibration_error(p: np.ndarray, y: np.ndarray, bins: int = BINS) -> float:
    """Σ_b (n_b / N) |mean confidence_b − share on a surface_b| over equal-width bins; NaN
    without flies."""
    rows = reliability(p, y, bins)
    total = sum(r["flies"] for r in rows)
    if total == 0:
        return math.nan
    return float(
        sum(
            r["flies"] * abs(r["mean_confidence"] - r["on_surface_share"])
            for r in rows
            if r["flies"]
        )
        / total
    )


# ---- fits --------------------------------------------------------------------------------


def fit_logistic(x: np.ndarray, y: np.ndarray, *, l2: float = 1e-6, steps: int = 50) -> np.ndarray:
    """Weights (intercept first) of the logistic regression of ``y`` (N,) on ``x`` (N, k) by
    Newton's method (iteratively reweighted least squares), a small ridge ``l2`` keeping it
    defined on separable data; stops when a step changes no weight by 1e-10 or after
    ``steps`` steps."""
    a = np.column_stack([np.ones(len(x)), np.asarray(x, dtype=np.float64)])
    y = np.asarray(y, dtype=np.float64)
    w = np.zeros(a.shape[1])
    ridge = l2 * len(y) * np.eye(a.shape[1])
    ridge[0, 0] = 0.0
    for _ in range(steps):
        p = 1.0 / (1.0 + np.exp(-(a @ w)))
        grad = a.T @ (p - y) + ridge @ w
        hess = (a * (p * (1 - p))[:, None]).T @ a + ridge
        step = np.linalg.solve(hess, grad)
        w -= step
        if np.max(np.abs(step)) < 1e-10:
            break
    return w


def fit_isotonic(x: np.ndarray, y: np.ndarray, *, knots: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """The non-decreasing least-squares fit of ``y`` on ``x`` (pool adjacent violators) as at
    most ``knots`` points (x, value) to interpolate between: the fit's blocks' mean x and
    value, thinned evenly."""
    order = np.argsort(x, kind="stable")
    xs, ys = np.asarray(x, dtype=np.float64)[order], np.asarray(y, dtype=np.float64)[order]
    # Blocks of equal x first (the fit is a function of x), then pooled.
    _, first = np.unique(xs, return_index=True)
    bounds = np.append(first, len(xs))
    sums_y = np.add.reduceat(ys, first)
    sums_x = np.add.reduceat(xs, first)
    weights = np.diff(bounds).astype(np.float64)
    value: list[float] = []
    weight: list[float] = []
    mean_x: list[float] = []
    for sy, sx, n in zip(sums_y, sums_x, weights, strict=True):
        value.append(sy / n)
        weight.append(n)
        mean_x.append(sx / n)
        while len(value) > 1 and value[-2] > value[-1]:
            n2, n1 = weight.pop(), weight.pop()
            v2, v1 = value.pop(), value.pop()
            x2, x1 = mean_x.pop(), mean_x.pop()
            weight.append(n1 + n2)
            value.append((v1 * n1 + v2 * n2) / (n1 + n2))
            mean_x.append((x1 * n1 + x2 * n2) / (n1 + n2))
    kx, kv = np.array(mean_x), np.array(value)
    if len(kx) > knots:
        pick = np.unique(np.linspace(0, len(kx) - 1, knots).round().astype(np.int64))
        kx, kv = kx[pick], kv[pick]
    return kx, kv


def fit_model(
    data: Labelled,
    kind: str,
    names: Sequence[str],
    *,
    min_distinctness: float,
    tau: float,
    engine: str,
    provenance: str,
) -> cf.ConfidenceModel:
    """A confidence model of ``kind`` on the features ``names``, fitted to ``data``: the
    logistic regression's score, and for "isotonic" that score's isotonic recalibration on
    the same flies."""
    if data.flies == 0:
        msg = "no judged flies to fit a confidence model on"
        raise LogError(msg)
    table = cf.derived(data.features, min_distinctness)
    x = np.column_stack([table[n] for n in names])
    w = fit_logistic(x, data.on_surface)
    knots: tuple[float, ...] = ()
    values: tuple[float, ...] = ()
    if kind == "isotonic":
        kx, kv = fit_isotonic(w[0] + x @ w[1:], data.on_surface)
        knots, values = tuple(float(v) for v in kx), tuple(float(v) for v in kv)
    return cf.ConfidenceModel(
        kind,
        tuple(names),
        coefficients=tuple(float(v) for v in w),
        knots=knots,
        values=values,
        min_distinctness=min_distinctness,
        tau=tau,
        engine=engine,
        provenance=provenance,
    )


def predict(model: cf.ConfidenceModel, data: Labelled) -> np.ndarray:
    return model.predict(data.features, np.ones(data.flies, dtype=bool))


# ---- the packaged model ------------------------------------------------------------------

# The packaged model's form (docs/export.md: chosen by leave-one-scene-out on the fitted
# runs; the held-out runs judge it, they did not choose it).
KIND = "logistic"
NAMES = (
    cf.QUANTILE,
    cf.QUANTILE_SQUARED,
    cf.LOG_AGE,
    cf.MEASURED,
    cf.DISTINCT,
    cf.PASSES,
    cf.QUANTILE_PASSES,
    cf.DISTINCT_PASSES,
)


def _describe(run: Path, log: Path) -> dict[str, Any]:
    sim = open_log(log).metadata().get(contract.SIMULATION_METADATA, {})
    return {"run": run.name, "log": log.name, "scene": sim.get("scene"), "seed": sim.get("seed")}


def calibrate(
    fit: Sequence[tuple[Path, Path]],
    check: Sequence[tuple[Path, Path]],
    config: MetricsConfig,
    *,
    command: str = "",
    kind: str = KIND,
    names: Sequence[str] = NAMES,
) -> tuple[cf.ConfidenceModel, list[dict[str, Any]]]:
    """The confidence model (``kind`` on ``names``) fitted on the (run, log) pairs
    ``fit``, and the ECE on each pair of ``fit`` and of ``check`` (held out: scenes and seeds
    not fitted on) as rows {run, log, scene, seed, role, flies, on_surface_share, ece}. The
    runs must share one engine configuration, which the model records."""
    digests = {engine_digest(open_log(run)) for run, _ in [*fit, *check]}
    if len(digests) != 1:
        msg = "the calibration runs were replayed with different engine configurations"
        raise LogError(msg)
    parts = {pair: labelled_run(pair[0], pair[1], config) for pair in [*fit, *check]}
    rule = _rule(open_log(fit[0][0]), config)
    provenance: dict[str, Any] = {
        "command": command,
        "fit": [_describe(*pair) for pair in fit],
        "held_out": [_describe(*pair) for pair in check],
    }
    model = fit_model(
        concatenate([parts[p] for p in fit]),
        kind,
        names,
        min_distinctness=rule.min_distinctness,
        tau=config.tau,
        engine=digests.pop(),
        provenance=json.dumps(provenance),
    )
    rows = []
    for role, pairs in (("fit", fit), ("held_out", check)):
        for pair in pairs:
            data = parts[pair]
            rows.append(
                {
                    **_describe(*pair),
                    "role": role,
                    "flies": data.flies,
                    "on_surface_share": float(data.on_surface.mean()) if data.flies else math.nan,
                    "ece": expected_calibration_error(predict(model, data), data.on_surface),
                }
            )
    held = concatenate([parts[p] for p in check])
    if held.flies:
        pooled = expected_calibration_error(predict(model, held), held.on_surface)
        provenance["held_out_ece_pooled"] = round(pooled, 4)
    provenance["ece"] = [{k: r[k] for k in ("run", "role", "ece")} for r in rows]
    for r in provenance["ece"]:
        r["ece"] = round(r["ece"], 4)
    return dataclasses.replace(model, provenance=json.dumps(provenance)), rows


class ConfidenceScore(NamedTuple):
    """The confidence's calibration on one run: ECE, flies judged, the reliability table."""

    ece: float
    flies: int
    table: list[dict[str, Any]]


def score_confidence(
    run: str | Path, log: str | Path, config: MetricsConfig, model: cf.ConfidenceModel
) -> ConfidenceScore:
    """The calibration of ``model`` on ``run``'s flies against ``log``'s truth, judged at the
    tolerance the model was fitted for."""
    import dataclasses

    data = labelled_run(run, log, dataclasses.replace(config, tau=model.tau))
    p = predict(model, data)
    return ConfidenceScore(
        expected_calibration_error(p, data.on_surface), data.flies, reliability(p, data.on_surface)
    )


class RuleComparison(NamedTuple):
    """Precision of the run's obstacle rule and of the flies of highest confidence, as many
    (the judged flies of a run: valid, in view, on known truth)."""

    points: int
    rule_precision: float
    confidence_precision: float


def compare_with_rule(data: Labelled, model: cf.ConfidenceModel) -> RuleComparison:
    """The rule's flies against the same number of flies of highest confidence (ties broken
    by the fitness's rank) over all the judged flies of ``data``."""
    m = int(data.obstacle.sum())
    if m == 0:
        return RuleComparison(0, math.nan, math.nan)
    p = predict(model, data)
    order = np.lexsort((data.features[cf.QUANTILE], model.score(data.features), p))[::-1][:m]
    return RuleComparison(
        m, float(data.on_surface[data.obstacle].mean()), float(data.on_surface[order].mean())
    )
