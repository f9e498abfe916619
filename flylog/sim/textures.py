"""Procedural surface textures: hashed value noise, a few octaves, with distance fading.

A texture is a function of a point on a surface, written in 2-D coordinates of that surface
(x, y for horizontal faces; along-face and z for vertical ones) plus an integer seed per
face. Both cameras therefore see the same texture where they see the same point, as they
would on a real surface. Octaves finer than about two pixels at the viewing distance are
faded to their mean, which keeps far ground from aliasing into sparkle (that would differ
between the two cameras and make stereo matching meaningless).

:func:`texture_column` (numba, one image column at a time, used by the renderer's kernel)
and :func:`texture_value_numpy` (the plain-numpy reference) give bit-identical values; tests
compare them.
"""

from __future__ import annotations

import math

import numba
import numpy as np

# Octaves: spacing = feature_size * _SPACING[k], weight _WEIGHT[k] (sum 1): coarse to fine.
# The finest octave (half the feature size) gives a 7×7 window structure at 1 m.
# The spacings must stay powers of two (see texture_column).
_SPACING = (4.0, 2.0, 1.0, 0.5)
_WEIGHT = (0.25, 0.25, 0.25, 0.25)
N_OCTAVES = len(_SPACING)
assert all(math.frexp(m)[0] == 0.5 for m in _SPACING), "octave spacings must be powers of 2"
_MASK = 0xFFFFFFFF
# The lattice hash (hash01_numpy): its int64 arithmetic is masked to 32 bits, so uint32
# arithmetic (which vectorises) gives the same bits.
_HX, _HY, _HS, _HM = 73856093, 19349663, 83492791, 0x45D9F3B
_U32 = np.uint32
_I32 = np.int32


@numba.njit(cache=True, inline="always")
def _mix01(h):
    """The last three rounds of the lattice hash, as a float in [0, 1)."""
    h = _U32(_U32(_U32(h >> _U32(16)) ^ h) * _U32(_HM))
    h = _U32(_U32(_U32(h >> _U32(16)) ^ h) * _U32(_HM))
    h = _U32(_U32(h >> _U32(16)) ^ h)
    # uint32 → float64 through int32 (AVX2 converts signed integers only); exact.
    return (np.float64(_I32(h ^ _U32(0x80000000))) + 2147483648.0) * (1.0 / 4294967296.0)


# error_model="numpy": no zero-division checks, whose branches would stop vectorisation.
@numba.njit(cache=True, error_model="numpy")
def texture_column(s, t, seed, feature_size, footprint, lo, hi, out, scratch):
    """Texture values of rows lo..hi-1 of 1-D arrays (s, t, seed, feature_size, footprint)
    into ``out``, as :func:`texture_value_numpy`, bit for bit; ``scratch`` is (3, >= hi).

    Branch-free octave loops the compiler vectorises; an octave is computed only over the
    rows between the first and the last where it is not faded out. Lattice coordinates
    (s / spacing) must lie within ±2**31 where an octave is visible.
    """
    # Spacings are feature_size times powers of two, so one division per pixel serves
    # every octave bit for bit: scaling by a power of two commutes with rounding.
    qs, qt, qf = scratch[0], scratch[1], scratch[2]
    for i in range(lo, hi):
        out[i] = 0.0
        qs[i] = s[i] / feature_size[i]
        qt[i] = t[i] / feature_size[i]
        qf[i] = feature_size[i] / footprint[i]
    for k in range(N_OCTAVES):
        mult = _SPACING[k]
        weight = _WEIGHT[k]
        first, last = hi, lo  # rows with fade > 0, i.e. spacing / footprint > 1
        for i in range(lo, hi):
            if qf[i] * mult > 1.0:
                first = min(first, i)
                last = i + 1
        # Elsewhere the full formula adds weight * (0.5 + 0 * (noise - 0.5)).
        for i in range(lo, first):
            out[i] += weight * 0.5
        for i in range(max(first, last), hi):
            out[i] += weight * 0.5
        if last > first:
            # Slices, so that the loop index is known to be non-negative (no wraparound
            # branch in the loop): that is what lets the loop vectorise.
            _add_octave(
                qs[first:last],
                qt[first:last],
                qf[first:last],
                seed[first:last],
                k,
                mult,
                1.0 / mult,
                weight,
                out[first:last],
            )


@numba.njit(cache=True, error_model="numpy")
def _add_octave(qs, qt, qf, seed, k, mult, inv, weight, out):
    for i in range(out.shape[0]):
        fade = min(max(qf[i] * mult - 1.0, 0.0), 1.0)
        x, y = qs[i] * inv, qt[i] * inv
        fx, fy = np.floor(x), np.floor(y)
        ix, iy = _U32(_I32(fx)), _U32(_I32(fy))
        hs = _U32(_U32(seed[i] * 4 + k) * _U32(_HS))
        hx0 = _U32(ix * _U32(_HX))
        hx1 = _U32(hx0 + _U32(_HX))
        hy0 = _U32(iy * _U32(_HY))
        hy1 = _U32(_U32(hy0 + _U32(_HY)) ^ hs)
        hy0 = _U32(hy0 ^ hs)
        a = _mix01(_U32(hx0 ^ hy0))
        b = _mix01(_U32(hx1 ^ hy0))
        c = _mix01(_U32(hx0 ^ hy1))
        d = _mix01(_U32(hx1 ^ hy1))
        tx, ty = x - fx, y - fy
        sx, sy = tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty)
        top = a + (b - a) * sx
        bottom = c + (d - c) * sx
        out[i] += weight * (0.5 + fade * (top + (bottom - top) * sy - 0.5))


def hash01_numpy(ix: np.ndarray, iy: np.ndarray, seed: np.ndarray) -> np.ndarray:
    """A lattice value in [0, 1): 32-bit integer hash of (ix, iy, seed) int64 arrays."""
    h = ((ix * 73856093) ^ (iy * 19349663) ^ (seed * 83492791)) & _MASK
    h = (((h >> 16) ^ h) * 0x45D9F3B) & _MASK
    h = (((h >> 16) ^ h) * 0x45D9F3B) & _MASK
    h = (h >> 16) ^ h
    return h / 4294967296.0


def value_noise_numpy(x: np.ndarray, y: np.ndarray, seed: np.ndarray) -> np.ndarray:
    """Smooth value noise in [0, 1) with unit lattice spacing."""
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
    """Octave sum in [0, 1) at surface coordinates (s, t) m (all arguments broadcast);
    ``footprint`` is the size of a pixel on the surface (m): octaves below two pixels fade to
    their mean 0.5. Plain-numpy reference of :func:`texture_column`."""
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


# Octaves (spacing in feature sizes, weight) of the 1-D noise that patterns the sky.
_SKY_OCTAVES = ((1.0, 0.5), (0.5, 0.3), (0.25, 0.2))


def value_noise_1d_numpy(x: np.ndarray, seed: int) -> np.ndarray:
    """Smooth 1-D value noise in [0, 1) of ``x`` (in feature sizes), three octaves.

    The sky is patterned by the product of this noise along the azimuth (one value per
    image column) and along the elevation (one per row): a 2-D pattern that is a function
    of the viewing direction only, computed once per frame.
    """
    x = np.asarray(x, dtype=float)
    total = np.zeros_like(x)
    for k, (spacing, weight) in enumerate(_SKY_OCTAVES):
        y = x / spacing
        fy = np.floor(y)
        i = fy.astype(np.int64)
        t = y - fy
        smooth = t * t * (3.0 - 2.0 * t)
        zero = np.zeros_like(i)
        octave_seed = np.full_like(i, 4 * seed + k)
        a = hash01_numpy(i, zero, octave_seed)
        b = hash01_numpy(i + 1, zero, octave_seed)
        total += weight * (a + (b - a) * smooth)
    return total
