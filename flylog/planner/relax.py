"""Red–black successive over-relaxation (SOR) of Laplace's equation on a grid.

Each sweep updates the "red" cells ((i + j) even) and then the "black" cells ((i + j) odd)
with ``u += omega * (factor * (sum of the 4 neighbours) - u)``: ``factor`` is 0.25 (the
mean of the neighbours, the paper's operator) unless the caller gives its own per cell, the
reciprocal of the neighbours' total weight for a weighted mean whose weighted neighbours
hold their value times their weight (see :func:`flylog.planner.obstacles.neighbour_factor`).
Cells where ``fixed`` is true (Dirichlet cells) and the outermost ring of the grid are never
written: the caller keeps the border fixed. Red cells only read black neighbours and vice
versa, so the vectorised numpy reference performs exactly the same arithmetic as the numba
loop, in the same order.
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np

from flylog.planner.config import Relaxation


class RelaxEnd(enum.Enum):
    """Which bound stopped :meth:`~flylog.planner.planner.HarmonicPlanner.relax_until`."""

    CONVERGED = "converged"  # the last sweep changed no cell by more than the tolerance
    MAX_SWEEPS = "max_sweeps"  # the sweep budget ran out first


@dataclass(frozen=True, slots=True)
class RelaxResult:
    sweeps: int
    max_change: float
    end: RelaxEnd


SweepFn = Callable[[np.ndarray, np.ndarray, float, int, "np.ndarray | None"], float]


@numba.njit(cache=True, nogil=True)
def _split_colours(
    u, fixed, factor, red, black, red_free, black_free, red_f, black_f
):  # pragma: no cover - compiled
    """Copy ``u`` into its red cells (row i, column 2m + i % 2 → red[i, m]) and black cells
    (column 2m + 1 − i % 2 → black[i, m]), ``factor`` likewise into ``*_f``; ``*_free`` is
    1.0 where a cell may be written (not fixed, not on the border) and 0.0 elsewhere."""
    h, w = u.shape
    for i in range(h):
        for j in range(w):
            writable = not (fixed[i, j] or i == 0 or i == h - 1 or j == 0 or j == w - 1)
            if j % 2 == i % 2:
                red[i, j // 2] = u[i, j]
                red_free[i, j // 2] = 1.0 if writable else 0.0
                red_f[i, j // 2] = factor[i, j]
            else:
                black[i, j // 2] = u[i, j]
                black_free[i, j // 2] = 1.0 if writable else 0.0
                black_f[i, j // 2] = factor[i, j]


@numba.njit(cache=True, nogil=True)
def _merge_colours(u, red, black):  # pragma: no cover - compiled
    h, w = u.shape
    for i in range(h):
        for j in range(w):
            u[i, j] = red[i, j // 2] if j % 2 == i % 2 else black[i, j // 2]


@numba.njit(cache=True, nogil=True)
def _relax_row(
    x, y, free, factor, omega, i, q, width, track, change
):  # pragma: no cover - compiled
    """Update the cells x[i, m] of one colour, at grid column 2m + q, from their four
    neighbours of the other colour y: y[i ± 1, m] above and below, y[i, m + q − 1] and
    y[i, m + q] left and right (``width``: the grid's columns). Returns the largest |change|
    so far if ``track``.

    Indices are unsigned so numba emits no negative-index test and LLVM vectorises."""
    up, down, side, row, writable, f = y[i - 1], y[i + 1], y[i], x[i], free[i], factor[i]
    lo = np.uint64(1 - q)  # first m whose column 2m + q is >= 1
    hi = np.uint64((width - 2 - q) // 2 + 1)  # past the last m whose column is <= width - 2
    left, right = np.uint64(q) - np.uint64(1), np.uint64(q)
    if track:
        for m in range(lo, hi):
            avg = f[m] * (((up[m] + down[m]) + side[m + left]) + side[m + right])
            d = omega * (avg - row[m]) * writable[m]
            row[m] += d
            change = max(change, abs(d))
    else:
        for m in range(lo, hi):
            avg = f[m] * (((up[m] + down[m]) + side[m + left]) + side[m + right])
            row[m] += omega * (avg - row[m]) * writable[m]
    return change


def sor_sweeps_numba(
    u: np.ndarray,
    fixed: np.ndarray,
    omega: float,
    sweeps: int,
    factor: np.ndarray | None = None,
) -> float:
    """Run ``sweeps`` red–black SOR sweeps on ``u`` (float64, in place); return the largest
    absolute change made during the last sweep (0.0 if ``sweeps`` is 0). ``factor`` (H, W):
    each cell's multiplier of its neighbours' sum (None: 0.25 everywhere).

    The same arithmetic as :func:`sor_sweeps_numpy`, cell for cell, made fast by three
    rearrangements that change no result: the two colours are stored apart (contiguous
    rows, so the update vectorises); the black cells of row i − 1 are updated right after
    the red cells of row i (they read only red rows i − 2 … i, all updated by then, and no
    red cell reads them later in the sweep); a fixed cell's update is multiplied by 0.0
    (it adds exactly 0) instead of skipped."""
    if factor is None:
        factor = np.full(u.shape, 0.25)
    return _sor_kernel(u, fixed, factor, float(omega), int(sweeps))


@numba.njit(cache=True, nogil=True)
def _sor_kernel(u, fixed, factor, omega, sweeps):  # pragma: no cover - compiled
    h, w = u.shape
    if sweeps <= 0 or h < 3 or w < 3:
        return 0.0
    half = (w + 1) // 2
    red, black = np.zeros((h, half)), np.zeros((h, half))
    red_free, black_free = np.zeros((h, half)), np.zeros((h, half))
    red_f, black_f = np.zeros((h, half)), np.zeros((h, half))
    _split_colours(u, fixed, factor, red, black, red_free, black_free, red_f, black_f)
    change = 0.0
    for sweep in range(sweeps):
        track = sweep == sweeps - 1
        for i in range(1, h):
            if i < h - 1:
                change = _relax_row(red, black, red_free, red_f, omega, i, i % 2, w, track, change)
            if i >= 2:
                k = i - 1
                q = 1 - k % 2
                change = _relax_row(black, red, black_free, black_f, omega, k, q, w, track, change)
    _merge_colours(u, red, black)
    return change


def sor_sweeps_numpy(
    u: np.ndarray,
    fixed: np.ndarray,
    omega: float,
    sweeps: int,
    factor: np.ndarray | None = None,
) -> float:
    """Plain-numpy reference of :func:`sor_sweeps_numba` (same arithmetic, same result)."""
    h, w = u.shape
    f = 0.25 if factor is None else factor[1:-1, 1:-1]
    ii, jj = np.indices((h - 2, w - 2))
    parity = (ii + jj) % 2  # interior (i, j) has grid parity (i + 1 + j + 1) % 2 == this
    free = ~fixed[1:-1, 1:-1]
    masks = [free & (parity == 0), free & (parity == 1)]
    change = 0.0
    for _ in range(sweeps):
        change = 0.0
        for mask in masks:
            avg = f * (((u[:-2, 1:-1] + u[2:, 1:-1]) + u[1:-1, :-2]) + u[1:-1, 2:])
            d = np.where(mask, omega * (avg - u[1:-1, 1:-1]), 0.0)
            u[1:-1, 1:-1] += d
            change = max(change, float(np.abs(d).max(initial=0.0)))
    return change


SWEEPS: dict[Relaxation, SweepFn] = {
    Relaxation.NUMBA: sor_sweeps_numba,
    Relaxation.NUMPY: sor_sweeps_numpy,
}


def sor_sweeps(
    u: np.ndarray,
    fixed: np.ndarray,
    omega: float,
    sweeps: int,
    kind: Relaxation,
    factor: np.ndarray | None = None,
) -> float:
    """Run ``sweeps`` sweeps with the chosen implementation; the last sweep's largest change."""
    if u.dtype != np.float64 or fixed.dtype != np.bool_ or u.shape != fixed.shape:
        msg = (
            f"sor_sweeps needs u float64 and fixed bool of one shape, got "
            f"{u.dtype}{u.shape} and {fixed.dtype}{fixed.shape}"
        )
        raise ValueError(msg)
    if factor is not None and (factor.dtype != np.float64 or factor.shape != u.shape):
        msg = (
            f"sor_sweeps needs factor float64 of shape {u.shape}, got {factor.dtype}{factor.shape}"
        )
        raise ValueError(msg)
    return float(SWEEPS[kind](u, fixed, float(omega), int(sweeps), factor))
