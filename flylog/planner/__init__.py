"""flylog.planner: the harmonic-function path planner (paper §2.3)."""

from flylog.planner.config import PlannerConfig, Relaxation
from flylog.planner.grid import GridGeometry, centred_origin
from flylog.planner.planner import HarmonicPlanner, RelaxEnd, RelaxResult
from flylog.planner.relax import sor_sweeps, sor_sweeps_numba, sor_sweeps_numpy
from flylog.planner.steering import Command, PathEnd, PlannedPath, Status

__all__ = [
    "Command",
    "GridGeometry",
    "HarmonicPlanner",
    "PathEnd",
    "PlannedPath",
    "PlannerConfig",
    "RelaxEnd",
    "RelaxResult",
    "Relaxation",
    "Status",
    "centred_origin",
    "sor_sweeps",
    "sor_sweeps_numba",
    "sor_sweeps_numpy",
]
