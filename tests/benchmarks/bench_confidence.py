"""The packaged confidence model on simulated runs and on the Middlebury motorcycle pair:
expected calibration error per run and pooled, and the precision of the flies of highest
confidence against the obstacle rule's at the same count (docs/export.md#confidence).

The runs are ``NAME.run.mcap`` beside ``NAME.mcap`` in ``FLYLOG_BENCH_CALIBRATION_DIR``
(default ``confidence-runs``, made by ``make confidence``; add others, e.g. fresh seeds, to
check on); without the directory only the motorcycle pair is measured."""

from __future__ import annotations

import dataclasses
import json
import os
import warnings
from pathlib import Path

from flylog.fly import confidence as cf
from flylog.metrics.calibration import (
    compare_with_rule,
    concatenate,
    expected_calibration_error,
    labelled_run,
    predict,
)
from flylog.metrics.config import MetricsConfig


def _motorcycle(out_dir: Path, seed: int) -> tuple[Path, Path]:
    from flylog.datasets.run import import_dataset
    from flylog.replay.config import ReplayConfig
    from flylog.replay.run import replay
    from tests.datasets.test_motorcycle import write_motorcycle

    root = out_dir / "confidence_motorcycle"
    log = root / "motorcycle.mcap"
    if not log.exists():
        write_motorcycle(root / "Motorcycle")
        import_dataset("middlebury", root, log)
    run = root / f"flies{seed}.mcap"
    if not run.exists():
        config = dataclasses.replace(ReplayConfig(), generations_per_frame=100, seed=seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            replay(log, run, config)
    return run, log


def run(out_dir: Path) -> list[dict]:
    model = cf.load()
    assert model is not None, "no packaged confidence model"
    fitted = {r["run"] for r in json.loads(model.provenance).get("fit", [])}
    folder = Path(os.environ.get("FLYLOG_BENCH_CALIBRATION_DIR", "confidence-runs"))
    pairs = sorted(folder.glob("*.run.mcap")) if folder.is_dir() else []
    figures: list[dict] = []
    pooled: dict[str, list] = {"fit": [], "held out": []}
    config = MetricsConfig(tau=model.tau)
    for path in pairs:
        log = path.with_name(path.name.removesuffix(".run.mcap") + ".mcap")
        data = labelled_run(path, log, config)
        role = "fit" if path.name in fitted else "held out"
        pooled[role].append(data)
        ece = expected_calibration_error(predict(model, data), data.on_surface)
        figures.append({"name": f"{path.name} ({role}): ECE", "value": ece, "unit": ""})
        c = compare_with_rule(data, model)
        figures.append(
            {
                "name": f"{path.name} ({role}): precision of the most confident",
                "value": c.confidence_precision,
                "unit": "",
                "note": f"the rule's {c.points} flies: {c.rule_precision:.4f}",
            }
        )
    for role, parts in pooled.items():
        if parts:
            data = concatenate(parts)
            ece = expected_calibration_error(predict(model, data), data.on_surface)
            figures.append({"name": f"pooled {role}: ECE", "value": ece, "unit": ""})
    for seed in (0, 1):
        data = labelled_run(*_motorcycle(out_dir, seed), config)
        p = predict(model, data)
        figures.append(
            {
                "name": f"Middlebury motorcycle, seed {seed}: ECE",
                "value": expected_calibration_error(p, data.on_surface),
                "unit": "",
                "note": f"{data.flies} flies, {data.on_surface.mean():.3f} on a surface, "
                f"mean confidence {p.mean():.3f}",
            }
        )
    return figures
