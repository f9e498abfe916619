"""flylog.experiments: the paper's experiments, reproduced with tables and plots.

``experiment_plan(name, out_dir, options)`` plans the cells of one of :data:`EXPERIMENTS`;
``flylog.experiments.parallel`` runs them, in this process (``run_experiment``: it writes
``out_dir/NAME/summary.md`` with its PNGs) or on a process pool. The modules are imported
only when run.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING

from flylog.errors import ConfigError

if TYPE_CHECKING:
    from flylog.experiments.cells import ExperimentPlan
    from flylog.experiments.common import ExperimentOptions

# name → (module, the function that plans its cells, what it reproduces)
EXPERIMENTS = MappingProxyType(
    {
        "proprioception": (
            "proprioception",
            "plan_proprioception",
            "proprioception on/off on turn, one generation per frame (Fig. 4/5)",
        ),
        "sonar": ("sonar", "plan_sonar", "sonar fusion on/off on near-obstacle (Fig. 9)"),
        "latency": (
            "latency",
            "plan_latency",
            "async vs sync vs SGBM: detection latency, planner reaction (Table 1)",
        ),
        "closed-loop": (
            "closed_loop",
            "plan_closed_loop",
            "closed-loop avoidance on corridor and clutter (Fig. 7/8)",
        ),
        "navigation": (
            "navigation",
            "plan_navigation",
            "closed loop on generated passages, clutter and dead-end worlds (issue 35)",
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


def experiment_plan(name: str, out_dir: Path, options: ExperimentOptions) -> ExperimentPlan:
    """The cells of the experiment ``name`` (one of :data:`EXPERIMENTS`), writing into
    ``out_dir/name/``."""
    experiment_names(name)
    module, function, _ = EXPERIMENTS[name]
    plan = getattr(importlib.import_module(f"flylog.experiments.{module}"), function)
    return plan(Path(out_dir), options)
