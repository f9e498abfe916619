"""Red–black successive over-relaxation (SOR) of Laplace's equation on a grid.

Each sweep updates the "red" cells ((i + j) even) and then the "black" cells ((i + j) odd)
with ``u += omega * (mean of the 4 neighbours - u)``. Cells where ``fixed`` is true
(Dirichlet cells) and the outermost ring of the grid are never written: the caller keeps
the border fixed. Red cells only read black neighbours and vice versa, so the vectorised
numpy reference performs exactly the same arithmetic as the numba loop, in the same order.
"""

from __future__ import annotations

from collections.abc import Callable

import numba
import numpy as np

from flylog.planner.config import Relaxation

SweepFn = Callable[[np.ndarray, np.ndarray, float, int], float]


@numba.njit(cache=True, nogil=True)
def sor_sweeps_numba(u: np.ndarray, fixed: np.ndarray, omega: float, sweeps: int) -> float:
    """Run ``sweeps`` red–black SOR sweeps on ``u`` (float64, in place); return the largest
    absolute change made during the last sweep (0.0 if ``sweeps`` is 0)."""
    h, w = u.shape
    change = 0.0
    for _ in range(sweeps):
        change = 0.0
        for colour in range(2):
            for i in range(1, h - 1):
                # first interior column j >= 1 with (i + j) % 2 == colour
                start = 1 + (i + 1 + colour) % 2
                for j in range(start, w - 1, 2):
                    if fixed[i, j]:
                        continue
                    avg = 0.25 * (((u[i - 1, j] + u[i + 1, j]) + u[i, j - 1]) + u[i, j + 1])
                    d = omega * (avg - u[i, j])
                    u[i, j] += d
                    ad = abs(d)
                    if ad > change:
                        change = ad
    return change


def sor_sweeps_numpy(u: np.ndarray, fixed: np.ndarray, omega: float, sweeps: int) -> float:
    """Plain-numpy reference of :func:`sor_sweeps_numba` (same arithmetic, same result)."""
    h, w = u.shape
    ii, jj = np.indices((h - 2, w - 2))
    parity = (ii + jj) % 2  # interior (i, j) has grid parity (i + 1 + j + 1) % 2 == this
    free = ~fixed[1:-1, 1:-1]
    masks = [free & (parity == 0), free & (parity == 1)]
    change = 0.0
    for _ in range(sweeps):
        change = 0.0
        for mask in masks:
            avg = 0.25 * (((u[:-2, 1:-1] + u[2:, 1:-1]) + u[1:-1, :-2]) + u[1:-1, 2:])
            d = np.where(mask, omega * (avg - u[1:-1, 1:-1]), 0.0)
            u[1:-1, 1:-1] += d
            change = max(change, float(np.abs(d).max(initial=0.0)))
    return change


SWEEPS: dict[Relaxation, SweepFn] = {
    Relaxation.NUMBA: sor_sweeps_numba,
    Relaxation.NUMPY: sor_sweeps_numpy,
}


def sor_sweeps(
    u: np.ndarray, fixed: np.ndarray, omega: float, sweeps: int, kind: Relaxation
) -> float:
    """Run ``sweeps`` sweeps with the chosen implementation; the last sweep's largest change."""
    if u.dtype != np.float64 or fixed.dtype != np.bool_ or u.shape != fixed.shape:
        msg = (
            f"sor_sweeps needs u float64 and fixed bool of one shape, got "
            f"{u.dtype}{u.shape} and {fixed.dtype}{fixed.shape}"
        )
        raise ValueError(msg)
    return float(SWEEPS[kind](u, fixed, float(omega), int(sweeps)))
