"""Procedural surface textures: hashed value noise, a few octaves, with distance fading.

A texture is a function of a point on a surface, written in 2-D coordinates of that surface
(x, y for horizontal faces; along-face and z for vertical ones) plus an integer seed per
face. Both cameras therefore see the same texture where they see the same point, as they
would on a real surface. Octaves finer than about two pixels at the viewing distance are
faded to their mean, which keeps far ground from aliasing into sparkle (that would differ
between the two cameras and make stereo matching meaningless).

Every function has a numba version (scalar, used by the renderer's kernel) and a plain numpy
version (vectorised, used by the reference renderer); tests compare them.
"""

from __future__ import annotations

import math

import numba
import numpy as np

# Octaves: spacing = feature_size * _SPACING[k], weight _WEIGHT[k] (sum 1): coarse to fine.
# The finest octave (half the feature size) gives a 7×7 window structure at 1 m.
_SPACING = (4.0, 2.0, 1.0, 0.5)
_WEIGHT = (0.25, 0.25, 0.25, 0.25)
N_OCTAVES = len(_SPACING)
_MASK = 0xFFFFFFFF


@numba.njit(cache=True)
def hash01(ix: int, iy: int, seed: int) -> float:
    """A lattice value in [0, 1): 32-bit integer hash of (ix, iy, seed), in int64 arithmetic."""
    h = ((ix * 73856093) ^ (iy * 19349663) ^ (seed * 83492791)) & _MASK
    h = (((h >> 16) ^ h) * 0x45D9F3B) & _MASK
    h = (((h >> 16) ^ h) * 0x45D9F3B) & _MASK
    h = (h >> 16) ^ h
    return h / 4294967296.0


@numba.njit(cache=True)
def value_noise(x: float, y: float, seed: int) -> float:
    """Smooth value noise in [0, 1) with unit lattice spacing."""
    fx, fy = math.floor(x), math.floor(y)
    ix, iy = int(fx), int(fy)
    tx, ty = x - fx, y - fy
    sx, sy = tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty)
    a = hash01(ix, iy, seed)
    b = hash01(ix + 1, iy, seed)
    c = hash01(ix, iy + 1, seed)
    d = hash01(ix + 1, iy + 1, seed)
    top = a + (b - a) * sx
    bottom = c + (d - c) * sx
    return top + (bottom - top) * sy


@numba.njit(cache=True)
def texture_value(s: float, t: float, seed: int, feature_size: float, footprint: float) -> float:
    """Octave sum in [0, 1) at surface coordinates (s, t) m; ``footprint`` is the size of a
    pixel on the surface (m): octaves below two pixels fade to their mean 0.5."""
    total = 0.0
    for k in range(len(_SPACING)):
        spacing = feature_size * _SPACING[k]
        weight = _WEIGHT[k]
        fade = min(max(spacing / footprint - 1.0, 0.0), 1.0)
        n = 0.5
        if fade > 0.0:
            n = value_noise(s / spacing, t / spacing, seed * 4 + k)
            n = 0.5 + fade * (n - 0.5)
        total += weight * n
    return total


@numba.njit(cache=True)
def texture_value_cached(
    s: float,
    t: float,
    seed: int,
    feature_size: float,
    footprint: float,
    keys: np.ndarray,
    corners: np.ndarray,
) -> float:
    """:func:`texture_value`, reusing the lattice values of the previous call per octave.

    Neighbouring pixels of a column mostly fall into the same lattice cell (octaves under
    two pixels are faded out), so this skips most hashing. ``keys`` (octaves, 3) int64 holds
    the cell (ix, iy, seed) whose four lattice values are in ``corners`` (octaves, 4); start
    with seeds of -1. Same arithmetic as :func:`value_noise`, so the results are identical.
    """
    total = 0.0
    for k in range(len(_SPACING)):
        spacing = feature_size * _SPACING[k]
        fade = min(max(spacing / footprint - 1.0, 0.0), 1.0)
        n = 0.5
        if fade > 0.0:
            x, y = s / spacing, t / spacing
            fx, fy = math.floor(x), math.floor(y)
            ix, iy, sd = int(fx), int(fy), seed * 4 + k
            if keys[k, 0] != ix or keys[k, 1] != iy or keys[k, 2] != sd:
                keys[k, 0], keys[k, 1], keys[k, 2] = ix, iy, sd
                corners[k, 0] = hash01(ix, iy, sd)
                corners[k, 1] = hash01(ix + 1, iy, sd)
                corners[k, 2] = hash01(ix, iy + 1, sd)
                corners[k, 3] = hash01(ix + 1, iy + 1, sd)
            tx, ty = x - fx, y - fy
            sx, sy = tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty)
            a, b, c, d = corners[k, 0], corners[k, 1], corners[k, 2], corners[k, 3]
            top = a + (b - a) * sx
            bottom = c + (d - c) * sx
            n = 0.5 + fade * (top + (bottom - top) * sy - 0.5)
        total += _WEIGHT[k] * n
    return total


def new_texture_cache() -> tuple[np.ndarray, np.ndarray]:
    """Empty (keys, corners) for :func:`texture_value_cached`."""
    return np.full((N_OCTAVES, 3), -1, dtype=np.int64), np.zeros((N_OCTAVES, 4))


def hash01_numpy(ix: np.ndarray, iy: np.ndarray, seed: np.ndarray) -> np.ndarray:
    """Plain-numpy reference of :func:`hash01` (int64 arrays)."""
    h = ((ix * 73856093) ^ (iy * 19349663) ^ (seed * 83492791)) & _MASK
    h = (((h >> 16) ^ h) * 0x45D9F3B) & _MASK
    h = (((h >> 16) ^ h) * 0x45D9F3B) & _MASK
    h = (h >> 16) ^ h
    return h / 4294967296.0


def value_noise_numpy(x: np.ndarray, y: np.ndarray, seed: np.ndarray) -> np.ndarray:
    """Plain-numpy reference of :func:`value_noise`."""
    fx, fy = np.floor(x), np.floor(y)
    ix, iy = fx.astype(np.int64), fy.astype(np.int64)
    tx, ty = x - fx, y - fy
    sx, sy = tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty)
    a, b = hash01_numpy(ix, iy, seed), hash01_numpy(ix + 1, iy, seed)
    c, d = hash01_numpy(ix, iy + 1, seed), hash01_numpy(ix + 1, iy + 1, seed)
    top = a + (b - a) * sx
    return top + ((c + (d - c) * sx) - top) * sy


def texture_value_numpy(
    s: np.ndarray, t: np.ndarray, seed: np.ndarray, feature_size: np.ndarray, footprint: np.ndarray
) -> np.ndarray:
    """Plain-numpy reference of :func:`texture_value` (all arguments broadcast)."""
    s, t, seed, feature_size, footprint = np.broadcast_arrays(
        s, t, np.asarray(seed, dtype=np.int64), feature_size, footprint
    )
    total = np.zeros(s.shape)
    for k, (mult, weight) in enumerate(zip(_SPACING, _WEIGHT, strict=True)):
        spacing = feature_size * mult
        fade = np.clip(spacing / footprint - 1.0, 0.0, 1.0)
        n = value_noise_numpy(s / spacing, t / spacing, seed * 4 + k)
        total += weight * (0.5 + fade * (n - 0.5))
    return total
