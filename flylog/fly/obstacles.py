"""Obstacle points from the flies: what the planner and the metrics read."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from flylog.config import param
from flylog.errors import ConfigError
from flylog.fly.config import Backend, EngineConfig
from flylog.geometry import StereoRig
from flylog.sensors import StereoPair

if TYPE_CHECKING:  # not at import: the metrics need only the rule, and no compiled code
    from flylog.fly.engine import FlyEngine
    from flylog.fly.population import Population


def quantile_linear(values: np.ndarray, q: float) -> float:
    """``np.quantile(values, q)`` (the default, linear method; same value, bit for bit) of a
    non-empty 1-D float array without NaN, by one partition: ~4× faster than np.quantile's
    general path, and the engine's thread finds the obstacle candidates for ~600 planner
    ticks and snapshots a minute of replay."""
    n = len(values)
    virtual = (n - 1) * q  # numpy's arithmetic and clipping, then its _lerp
    lo = min(max(math.floor(virtual), 0), n - 1)
    hi = min(lo + 1, n - 1)
    gamma = virtual - (-1 if virtual >= n - 1 else lo)
    part = np.partition(values, (lo, hi)) if hi > lo else np.partition(values, lo)
    a, b = float(part[lo]), float(part[hi])
    diff = b - a
    return b - diff * (1 - gamma) if gamma >= 0.5 else a + diff * gamma


def obstacle_mask(
    xyz: np.ndarray,
    fitness: np.ndarray,
    *,
    min_fitness: float | None = None,
    quantile: float | None = None,
    ground_margin: float = 0.05,
    age: np.ndarray | None = None,
    min_age: int = 0,
) -> np.ndarray:
    """(N,) bool: the flies taken for obstacles, from the arrays a population (or a ``/flies``
    point cloud) holds: valid (fitness > 0), fitness above a threshold, z above the ground
    by more than ``ground_margin`` m and, given ``age``, at least ``min_age`` generations old.

    Give exactly one threshold: ``min_fitness`` (absolute, in fitness units, which depend on
    the images' contrast) or ``quantile`` in [0, 1) of the positive fitnesses (scale-free:
    ``quantile=0.5`` keeps the better half of the valid flies).
    """
    if (min_fitness is None) == (quantile is None):
        msg = "give exactly one of min_fitness or quantile"
        raise ValueError(msg)
    if quantile is not None and not 0.0 <= quantile < 1.0:
        msg = f"quantile must be in [0, 1), got {quantile}"
        raise ValueError(msg)
    fitness = np.asarray(fitness)
    xyz = np.asarray(xyz)
    if xyz.shape != (len(fitness), 3):
        msg = f"xyz must be ({len(fitness)}, 3) like fitness, got {xyz.shape}"
        raise ValueError(msg)
    positive = fitness > 0
    if not positive.any():
        return np.zeros(len(fitness), dtype=bool)
    if quantile is not None:
        threshold = quantile_linear(fitness[positive], quantile)
    else:
        threshold = float(min_fitness)  # type: ignore[arg-type]
    keep = positive & (fitness > threshold) & (xyz[:, 2] > ground_margin)
    if age is not None and min_age > 0:
        keep &= np.asarray(age) >= min_age
    return keep


@dataclass(frozen=True)
class ObstacleFlies:
    """Which flies count as obstacles: for the planner, and for the metrics of a run."""

    quantile: float = param(
        0.5, help="keep flies above this quantile of the positive fitnesses", min=0.0, max=0.99
    )
    ground_margin: float = param(
        0.05, help="and at least this high above the ground", unit="m", min=0.0
    )
    min_age: int = param(
        3,
        help="and survivors of at least this many selections: a fly that has not yet been "
        "through selection is a random guess, not evidence (this keeps the planner from "
        "reacting to a population that has not converged yet)",
        unit="generations",
        min=0,
    )
    min_distinctness: float = param(
        1.5,
        help="and, when above 0, a distinctness (flylog.fly.distinct) of at least this: the "
        "fly's vision fitness over the best one of its left pixel at the disparities shifted "
        "by distinct_shifts. It rejects flies on stretches that match at many depths "
        "(horizontal edges, smooth sky or ground). 0 turns the test off (the paper's rule)",
        min=0.0,
    )
    distinct_shifts: tuple[int, ...] = param(
        (-4, -2, 2, 4),
        help="disparity shifts at which a fly's rivals along the epipolar line are scored",
        unit="px",
    )
    distinct_at_infinity: bool = param(
        True,
        help="one more rival: the fly's left pixel at disparity 0, the background at "
        "infinity (the sky matches best there, where no fly can be: on a striped sky flies "
        "settled on false matches that beat their ±2 and ±4 px neighbours)",
    )

    def __post_init__(self) -> None:
        if self.min_distinctness > 0 and (not self.distinct_shifts or 0 in self.distinct_shifts):
            msg = (
                "obstacles.distinct_shifts must be non-zero disparity shifts (px), at least "
                f"one, when min_distinctness > 0; got {list(self.distinct_shifts)}"
            )
            raise ConfigError(msg)

    @property
    def uses_distinctness(self) -> bool:
        return self.min_distinctness > 0

    def mask(
        self,
        xyz: np.ndarray,
        fitness: np.ndarray,
        age: np.ndarray | None,
        distinct: np.ndarray | None = None,
    ) -> np.ndarray:
        """(N,) bool: the obstacle flies; ``distinct`` (from :meth:`distinct_of`) is required
        when the rule uses distinctness."""
        return self.keep(self.candidates(xyz, fitness, age), distinct)

    def candidates(
        self, xyz: np.ndarray, fitness: np.ndarray, age: np.ndarray | None
    ) -> np.ndarray:
        """(N,) bool: the flies every test but distinctness keeps (the ones it measures)."""
        return obstacle_mask(
            xyz,
            fitness,
            quantile=self.quantile,
            ground_margin=self.ground_margin,
            age=age,
            min_age=self.min_age,
        )

    def keep(self, candidates: np.ndarray, distinct: np.ndarray | None) -> np.ndarray:
        """(N,) bool: the ``candidates`` whose ``distinct`` passes, when the rule reads it."""
        if not self.uses_distinctness:
            return candidates
        if distinct is None:
            msg = (
                f"this obstacle rule needs each fly's distinctness (min_distinctness "
                f"{self.min_distinctness:g}), and none was given (a /flies cloud without "
                "a 'distinct' field?)"
            )
            raise ValueError(msg)
        return candidates & (np.asarray(distinct) >= self.min_distinctness)  # NaN: not measured

    def distinct_of(
        self,
        xyz: np.ndarray,
        candidates: np.ndarray,
        pair: StereoPair | None,
        rig: StereoRig,
        engine: EngineConfig,
    ) -> np.ndarray | None:
        """(N,) float: the distinctness of the ``candidates`` (from :meth:`candidates`),
        measured on ``pair`` (the images their fitness was), NaN for the others; None when
        the rule does not use distinctness. Costs ``1 + len(distinct_shifts)`` fitness
        evaluations a candidate, one more with ``distinct_at_infinity``
        (:meth:`distinct_evaluations`), with the engine's fitness
        (window, guard, gradient)."""
        if not self.uses_distinctness:
            return None
        out = np.full(len(candidates), np.nan)
        if pair is None:
            return out
        from flylog.fly.distinct import distinctness  # compiled code: only when measured

        measured = np.flatnonzero(candidates)
        out[measured] = distinctness(
            pair.left,
            pair.right,
            np.asarray(xyz)[measured],
            rig,
            engine.window,
            engine.guard,
            self.distinct_shifts,
            gradient=engine.gradient,
            similarity=engine.similarity,
            subpixel=engine.subpixel,
            use_numba=engine.backend is Backend.NUMBA,
            infinity=self.distinct_at_infinity,
            readout=pair.readout,
        )
        return out

    def distinct_evaluations(self, candidates: np.ndarray) -> int:
        """The fitness evaluations :meth:`distinct_of` makes for these ``candidates``."""
        if not self.uses_distinctness:
            return 0
        return int(np.count_nonzero(candidates)) * self._evaluations_a_fly

    def most_distinct_evaluations(self, flies: int) -> int:
        """The most :meth:`distinct_evaluations` can be for a population of ``flies``."""
        return flies * self._evaluations_a_fly if self.uses_distinctness else 0

    @property
    def _evaluations_a_fly(self) -> int:
        return 1 + len(self.distinct_shifts) + int(self.distinct_at_infinity)


def obstacle_points(
    source: FlyEngine | Population,
    *,
    min_fitness: float | None = None,
    quantile: float | None = None,
    ground_margin: float = 0.05,
    min_age: int = 0,
) -> np.ndarray:
    """(M, 3) positions (base_link) of the flies :func:`obstacle_mask` keeps."""
    from flylog.fly.engine import FlyEngine

    pop = source.population if isinstance(source, FlyEngine) else source
    keep = obstacle_mask(
        pop.xyz,
        pop.fitness,
        min_fitness=min_fitness,
        quantile=quantile,
        ground_margin=ground_margin,
        age=pop.age,
        min_age=min_age,
    )
    return pop.xyz[keep].copy()
