"""The obstacle rule's answers for the published population, found once a publication:
planner ticks and snapshots of the same population share them.

Two caches, one per thread: :class:`Candidates` runs where the clock calls the pipeline
(it charges the distinctness test's evaluations to the next generation), :class:`Evidence`
where the planner's jobs run (it measures that distinctness)."""

from __future__ import annotations

import numpy as np

from flylog.fly.config import EngineConfig
from flylog.fly.obstacles import ObstacleFlies
from flylog.fly.population import Population
from flylog.geometry import StereoRig
from flylog.sensors import StereoPair


class Candidates:
    """The flies of a published population whose distinctness the rule reads."""

    def __init__(self, rule: ObstacleFlies) -> None:
        self._rule = rule
        self._found: tuple[int, np.ndarray] | None = None  # (generation, mask)

    def of(self, pop: Population | None, generation: int) -> tuple[np.ndarray | None, int]:
        """The candidates of ``pop``, published at ``generation`` (None when the rule reads
        none), and the fitness evaluations measuring them costs: non-zero only the first
        time a publication is asked for, to be charged to the next generation."""
        rule = self._rule
        if pop is None or not rule.uses_distinctness:
            return None, 0
        evaluations = 0
        if self._found is None or self._found[0] != generation:
            candidates = rule.candidates(pop.xyz, pop.fitness, pop.age)
            self._found = (generation, candidates)
            evaluations = rule.distinct_evaluations(candidates)
        return self._found[1], evaluations


class Evidence:
    """The obstacle rule's mask of a published population, and its candidates'
    distinctness."""

    def __init__(self, rule: ObstacleFlies, rig: StereoRig, engine: EngineConfig) -> None:
        self._rule = rule
        self._rig = rig
        self._engine = engine
        self._found: tuple[int, np.ndarray, np.ndarray | None] | None = None

    def of(
        self,
        pop: Population,
        pair: StereoPair | None,
        generation: int,
        candidates: np.ndarray | None,
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """The mask of ``pop``, published at ``generation`` and scored on ``pair``, and the
        distinctness of its ``candidates`` (None when the rule reads none)."""
        if self._found is not None and self._found[0] == generation:
            return self._found[1], self._found[2]
        rule = self._rule
        if candidates is None:
            mask, distinct = rule.mask(pop.xyz, pop.fitness, pop.age), None
        else:
            distinct = rule.distinct_of(pop.xyz, candidates, pair, self._rig, self._engine)
            mask = rule.keep(candidates, distinct)
        self._found = (generation, mask, distinct)
        return mask, distinct
