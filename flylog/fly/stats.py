"""What one generation of a stereo engine did: the record both engines (the fly engine and
the SGBM baseline) return to replay, which charges its evaluations to the virtual clock."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class GenerationStats:
    """What one generation did; ``evaluations`` lets replay charge virtual time. The
    population's fitness figures are :func:`flylog.fly.population.fitness_summary` of
    :attr:`FlyEngine.population`, computed by whoever needs them (a median per generation
    would cost more than the rest of these)."""

    generation: int
    evaluations: int
    image_stamp_ns: int
    survivors: int
    offspring: int
    immigrants: int
    sonar_immigrants: int
