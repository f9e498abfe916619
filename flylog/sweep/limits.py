"""A sweep's bounds, checked from its spec before anything is planned or written: the
number of cells, and the estimated size of what its cells and simulated inputs write (the
estimates of :mod:`flylog.budget`, which bound ``flylog simulate`` and ``replay``)."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import NamedTuple

from flylog.budget import SWEEP_MAX_CELLS, SWEEP_MAX_OUTPUT_SIZE, replay_output_bytes, size_text
from flylog.errors import FlylogError, LimitError
from flylog.sweep.spec import Drive, SweepSpec


@dataclass(frozen=True)
class SweepLimits:
    max_cells: int = SWEEP_MAX_CELLS
    max_output_size: int = SWEEP_MAX_OUTPUT_SIZE


def cell_count(spec: SweepSpec) -> int:
    """How many cells ``spec`` makes: inputs × variants × grid points × engine seeds."""
    inputs = len(spec.logs) + sum(len(s.seeds) for s in spec.simulate)
    points = math.prod(len(values) for _, values in spec.grid)
    return inputs * len(spec.variants) * points * len(spec.seeds)


class _Input(NamedTuple):
    seconds: float  # of log each of its cells replays
    copies: int  # inputs of the entry (a [[simulate]] entry's seeds)
    once_bytes: float  # its logs, simulated once before the cells (plan-driven)
    cell_bytes: float  # the log each cell simulates (a closed loop)


def _inputs(spec: SweepSpec) -> list[_Input]:
    """Each input's time span and what simulating it writes."""
    from flylog.io import open_log
    from flylog.scene.load import load_scene
    from flylog.sim.run import SimulationOptions, simulation_budget, simulation_duration

    out = []
    for log in spec.logs:
        try:
            reader = open_log(log)
            seconds = max(0.0, (reader.end_ns - reader.start_ns) / 1e9)
        except FlylogError:  # an unreadable log: its cells fail and say why; it writes nothing
            seconds = 0.0
        out.append(_Input(seconds, 1, 0.0, 0.0))
    for entry in spec.simulate:
        scene = load_scene(entry.scene)
        options = SimulationOptions(
            duration=entry.duration, resolution=entry.resolution, frame_rate=entry.frame_rate
        )
        made = simulation_budget(scene, options).output_bytes
        seconds = simulation_duration(scene, options)
        n = len(entry.seeds)
        if entry.drive is Drive.PLAN:
            out.append(_Input(seconds, n, made * n, 0.0))
        else:
            out.append(_Input(seconds, n, 0.0, made))
    return out


def check_sweep(spec: SweepSpec, limits: SweepLimits) -> None:
    """LimitError (``parameter``: the limit) for a sweep over ``limits``."""
    cells = cell_count(spec)
    if cells > limits.max_cells:
        msg = f"{spec.source}: the sweep has {cells} cells, over the limit of {limits.max_cells}"
        raise LimitError(msg, parameter="max_cells")
    configs = [
        spec.config(variant, point, 0)
        for variant, point in itertools.product(spec.variants, spec.grid_points())
    ]
    total = 0.0
    for item in _inputs(spec):
        cells_of = len(configs) * len(spec.seeds) * item.copies
        runs = sum(replay_output_bytes(c, item.seconds) for c in configs)
        total += runs * len(spec.seeds) * item.copies + item.cell_bytes * cells_of
        total += item.once_bytes
    if total > limits.max_output_size:
        msg = (
            f"{spec.source}: the sweep's {cells} cells would write about {size_text(total)}, over "
            f"the limit of {size_text(limits.max_output_size)} on outputs"
        )
        raise LimitError(msg, parameter="max_output_size")
