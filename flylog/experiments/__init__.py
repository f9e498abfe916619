"""flylog.experiments: the paper's experiments, reproduced with tables and plots.

``run_experiment(name, out_dir, options)`` runs one of :data:`EXPERIMENTS` and writes
``out_dir/NAME/summary.md`` with its PNGs; the modules are imported only when run.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING

from flylog.errors import ConfigError

if TYPE_CHECKING:
    from flylog.experiments.common import ExperimentOptions, ExperimentResult

# name → (module, function, what it reproduces)
EXPERIMENTS = MappingProxyType(
    {
        "proprioception": (
            "proprioception",
            "run_proprioception",
            "proprioception on/off on turn, one generation per frame (Fig. 4/5)",
        ),
        "sonar": ("sonar", "run_sonar", "sonar fusion on/off on near-obstacle (Fig. 9)"),
        "latency": (
            "latency",
            "run_latency",
            "async vs sync vs SGBM: detection latency, planner reaction (Table 1)",
        ),
        "closed-loop": (
            "closed_loop",
            "run_closed_loop",
            "closed-loop avoidance on corridor and clutter (Fig. 7/8)",
        ),
    }
)


def experiment_names(name: str) -> list[str]:
    """The experiments ``name`` stands for ("all": every one); ConfigError if unknown."""
    if name == "all":
        return list(EXPERIMENTS)
    if name not in EXPERIMENTS:
        msg = f"unknown experiment {name!r}: choose one of {', '.join([*EXPERIMENTS, 'all'])}"
        raise ConfigError(msg)
    return [name]


def run_experiment(
    name: str,
    out_dir: Path,
    options: ExperimentOptions,
    *,
    on_progress: Callable[[float, float], None] | None = None,
) -> ExperimentResult:
    """Run the experiment ``name`` (one of :data:`EXPERIMENTS`) into ``out_dir/name/``."""
    experiment_names(name)
    module, function, _ = EXPERIMENTS[name]
    run = getattr(importlib.import_module(f"flylog.experiments.{module}"), function)
    return run(Path(out_dir), options, on_progress=on_progress)
