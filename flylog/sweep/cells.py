"""A sweep's cells: inputs × variants × grid points × engine seeds, each with the work a
worker does and the fingerprint that makes a sweep resumable.

A cell's fingerprint is a digest of its input's content (the log's bytes; for a simulated
input, the scene file's bytes and the simulation options), its effective configuration
(replay and metrics) and flylog's version: a cell whose fingerprint is unchanged is not
run again.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import flylog
from flylog.config import to_mapping
from flylog.io.inputs import open_input, read_input_text
from flylog.metrics.config import MetricsConfig
from flylog.replay.config import ReplayConfig
from flylog.sweep.spec import Drive, SimulateInput, SweepSpec

INPUTS_DIR = "inputs"
RUNS_DIR = "runs"
_READ_BLOCK = 1 << 20


def digest(value: Any) -> str:
    """SHA-256 of a JSON-able value, keys sorted."""
    text = json.dumps(value, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def file_digest(path: Path) -> str:
    """SHA-256 of a file's bytes."""
    h = hashlib.sha256()
    with open_input(path, "an input of the sweep") as fh:
        while block := fh.read(_READ_BLOCK):
            h.update(block)
    return h.hexdigest()


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", text).strip("-")[:40] or "x"


@dataclass(frozen=True)
class SimulationTask:
    """One log to simulate (a plan-driven [[simulate]] entry and seed), or the closed-loop
    simulation of a cell (``config`` set: the engine and planner drive)."""

    scene: Path
    seed: int
    output: Path
    duration: float | None
    resolution: tuple[int, int] | None
    frame_rate: float | None
    fingerprint: str
    config: ReplayConfig | None = None


@dataclass(frozen=True)
class SimulatedInput:
    """A plan-driven simulated log: where it goes and the task that makes it."""

    label: str
    task: SimulationTask


@dataclass(frozen=True)
class Cell:
    """One run of a sweep and what its row says about it."""

    index: int
    input: str  # the log's path, or scene@seed for a simulated input
    input_kind: str  # log, simulate (plan-driven, replayed) or closed_loop
    input_seed: int | None  # the simulation's seed (None for a given log)
    seed: int  # the engine's
    variant: str
    point: tuple[tuple[str, Any], ...]  # grid key → value
    config: ReplayConfig
    metrics: MetricsConfig
    directory: Path  # DIR/runs/<id>
    log: Path | None  # the log to replay (None: closed loop, the cell simulates it)
    simulation: SimulationTask | None  # closed loop: what the cell simulates
    fingerprint: str

    @property
    def run(self) -> Path:
        return self.directory / "run.mcap"

    @property
    def metrics_output(self) -> Path:
        return self.directory / "metrics.parquet"

    @property
    def record(self) -> Path:
        """``cell.json``: the fingerprint and the row of a finished cell."""
        return self.directory / "cell.json"


def _simulation_key(entry: SimulateInput, seed: int) -> dict[str, Any]:
    return {
        "scene": read_input_text(entry.scene, "the scene file"),
        "seed": seed,
        "duration": entry.duration,
        "resolution": entry.resolution,
        "frame_rate": entry.frame_rate,
    }


def simulated_inputs(spec: SweepSpec, out_dir: Path) -> list[SimulatedInput]:
    """The plan-driven logs to simulate under ``DIR/inputs/`` before the cells replay them."""
    out = []
    for entry in spec.simulate:
        if entry.drive is not Drive.PLAN:
            continue
        for seed in entry.seeds:
            key = _simulation_key(entry, seed)
            fp = digest({"simulation": key, "version": flylog.__version__})
            name = f"{_slug(entry.scene.stem)}-seed{seed}-{fp[:8]}.mcap"
            task = SimulationTask(
                scene=entry.scene,
                seed=seed,
                output=out_dir / INPUTS_DIR / name,
                duration=entry.duration,
                resolution=entry.resolution,
                frame_rate=entry.frame_rate,
                fingerprint=fp,
            )
            out.append(SimulatedInput(f"{entry.scene}@seed{seed}", task))
    return out


def sweep_cells(spec: SweepSpec, out_dir: Path, simulated: list[SimulatedInput]) -> list[Cell]:
    """Every cell of ``spec``, in a fixed order: input, variant, grid point, engine seed."""
    # (label, kind, input seed, log path, content fingerprint, closed-loop entry)
    inputs: list[tuple[str, str, int | None, Path | None, str, SimulateInput | None]] = [
        (str(p), "log", None, p, file_digest(p), None) for p in spec.logs
    ]
    inputs += [
        (s.label, "simulate", s.task.seed, s.task.output, s.task.fingerprint, None)
        for s in simulated
    ]
    for entry in spec.simulate:
        if entry.drive is Drive.PLANNER:
            for seed in entry.seeds:
                fp = digest(_simulation_key(entry, seed))
                inputs.append((f"{entry.scene}@seed{seed}", "closed_loop", seed, None, fp, entry))
    cells = []
    combos = itertools.product(inputs, spec.variants, spec.grid_points(), spec.seeds)
    for index, (inp, variant, point, seed) in enumerate(combos):
        label, kind, input_seed, log, input_fp, entry = inp
        config = spec.config(variant, point, seed)
        identity = {
            "input": label,
            "kind": kind,
            "variant": variant.name,
            "point": to_mapping(point),
            "seed": seed,
        }
        fingerprint = digest(
            {
                "input": input_fp,
                "kind": kind,
                "config": to_mapping(config),
                "metrics": to_mapping(spec.metrics),
                "version": flylog.__version__,
            }
        )
        stem = Path(label.split("@")[0]).stem
        name = f"{_slug(stem)}-{_slug(variant.name)}-s{seed}-{digest(identity)[:10]}"
        directory = out_dir / RUNS_DIR / name
        simulation = None
        if entry is not None and input_seed is not None:
            simulation = SimulationTask(
                scene=entry.scene,
                seed=input_seed,
                output=directory / "run.mcap",
                duration=entry.duration,
                resolution=entry.resolution,
                frame_rate=entry.frame_rate,
                fingerprint=fingerprint,
                config=config,
            )
        cells.append(
            Cell(
                index=index,
                input=label,
                input_kind=kind,
                input_seed=input_seed,
                seed=seed,
                variant=variant.name,
                point=point,
                config=config,
                metrics=spec.metrics,
                directory=directory,
                log=log,
                simulation=simulation,
                fingerprint=fingerprint,
            )
        )
    return cells
