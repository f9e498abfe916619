"""The compiled generation's inputs as typed bundles: named tuples that numba passes as
tuples, each field read by name inside the kernels (a swapped argument is a wrong name, not a
silent swap). Measured in ``tests/benchmarks/bench_fly.py`` (``_bundle_figures``) against
the same kernels called with their fields as positional arguments."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Images(NamedTuple):
    """The pair being scored and how: (H, W·C) uint8 rows, the rig's constants
    (:func:`~flylog.fly.fitness.rig_constants`), the window, guard, the weight of gy² in the
    Sobel norm² (:func:`~flylog.fly.fitness_terms.gy_weight`), whether the right window is
    sampled at the exact right projection, the pair's stamp, and its rolling shutter: the
    robot's motion per row (:func:`~flylog.geometry.rolling.row_motion`) and whether it is
    non-zero (``rolling``: each fly is projected at its row's time; otherwise every row is
    at the stamp). The similarity measure travels beside it (:mod:`flylog.fly.measure`)."""

    lrows: np.ndarray
    rrows: np.ndarray
    channels: int
    k: np.ndarray
    window: int
    guard: float
    gy_weight: int
    subpixel: bool
    stamp: int
    row_motion: np.ndarray
    rolling: bool


class Flies(NamedTuple):
    """A population's arrays (:class:`~flylog.fly.population.Population`'s fields)."""

    xyz: np.ndarray
    fitness: np.ndarray
    vision: np.ndarray
    stale: np.ndarray
    stamp_ns: np.ndarray
    age: np.ndarray


class Fusion(NamedTuple):
    """The sonar term of the fitness (:func:`~flylog.fly.fusion.score_into`): fired sonars
    (F, 5), cos of the half cone, tolerance and bonus."""

    sonars: np.ndarray
    cos_half_cone: float
    tolerance: float
    bonus: float


class Selection(NamedTuple):
    """Survivors, sharing and their scratch (:func:`~flylog.fly.population.select_into_kernel`)."""

    survivors: int
    sharing: bool
    coefficient: float
    work: np.ndarray
    radius: float
    grid: np.ndarray
    ints: np.ndarray
    floats: np.ndarray
    counts: np.ndarray


class Breeding(NamedTuple):
    """Children and immigrants (:func:`~flylog.fly.operators.immigrants_and_children_into`):
    crossover rates, mutation scales, the newcomers' constants, the sonar arcs and how many
    immigrants (and of those, from the sonar) to make."""

    rate2: float
    rate3: float
    sigma_px: float
    sigma_d: float
    newcomer_k: np.ndarray
    arcs: np.ndarray
    half_cone: float
    arc_k: np.ndarray
    tries: int
    n_sonar: int
    n_immigrants: int


class Scouting(NamedTuple):
    """This generation's scouts (:meth:`flylog.fly.scouts.Scouting.bundle`): their share
    of the uniform immigrants (0: none), the strip, K depths, constants and scratch."""

    fraction: float
    c0: float
    c1: float
    in_right: bool
    n_depths: int
    k: np.ndarray
    candidates: np.ndarray
    candidate_index: np.ndarray
    candidate_fitness: np.ndarray


class Scratch(NamedTuple):
    """Index arrays: (N,) int64 scratch for the stale flies, 0…N−1, the newcomers' rows
    (those after the survivors) and the row order's (3, ≥ max(N, H + 2)) scratch."""

    stale_index: np.ndarray
    everyone: np.ndarray
    newcomers: np.ndarray
    row_scratch: np.ndarray
