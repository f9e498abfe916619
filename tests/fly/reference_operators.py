"""The paper's breeding operators one by one (mutation, the two crossovers, children of
survivors), built from the same arithmetic as :func:`flylog.fly.operators.newcomers_numpy`:
only tests call them."""

from __future__ import annotations

import numpy as np

from flylog.fly.operators import (
    _crossover2_by,
    _crossover3_by,
    _mutated_by,
    newcomer_constants,
    newcomers_into,
    newcomers_numpy,
)
from flylog.geometry import StereoRig


def mutated(
    rng: np.random.Generator,
    xyz: np.ndarray,
    rig: StereoRig,
    *,
    sigma_px: float,
    sigma_disparity_px: float,
    d_min: float,
    d_max: float,
) -> np.ndarray:
    """Gaussian mutation in (left-image position, disparity) space.

    The fly moves by N(0, σ_px²) in u and v and by N(0, σ_d²) in disparity f·b/z (inverse
    depth in pixels), which is the space where the fitness is evaluated and where the sharing
    radius R — the mean distance between neighbouring flies — is measured. The disparity is
    kept within the searched depths [d_min, d_max].
    """
    noise = rng.standard_normal((len(xyz), 3))
    return _mutated_by(noise, xyz, rig, sigma_px, sigma_disparity_px, d_min, d_max)


def crossover2(rng: np.random.Generator, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Barycentric two-parent crossover: λa + (1−λ)b, λ ~ U[0, 1] (on the segment)."""
    return _crossover2_by(rng.random((len(a), 1)), a, b)


def crossover3(rng: np.random.Generator, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Barycentric three-parent crossover: λa + μb + (1−λ−μ)c with (λ, μ) uniform in the
    triangle λ, μ ≥ 0, λ + μ ≤ 1 (inside the parents' triangle)."""
    return _crossover3_by(_triangle_weights(rng, len(a)), a, b, c)


def _triangle_weights(rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, 2) (λ, μ) uniform in the triangle: a uniform square folded along its diagonal."""
    w = rng.random((n, 2))
    folded = w.sum(axis=1) > 1.0
    w[folded] = 1.0 - w[folded]
    return w


def offspring(
    rng: np.random.Generator,
    parents: np.ndarray,
    n: int,
    rig: StereoRig,
    *,
    rate2: float,
    rate3: float,
    sigma_px: float,
    sigma_disparity_px: float,
    d_min: float,
    d_max: float,
    use_numba: bool = False,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """``n`` children of ``parents`` (M, 3): a share ``rate2`` by two-parent crossover,
    ``rate3`` by three-parent crossover, the rest by mutation of one parent. Parents are
    drawn uniformly (with replacement) among the survivors. Written into ``out`` (n, 3) when
    given (C-contiguous float64 for the compiled path), which is returned."""
    if out is None:
        out = np.empty((n, 3))
    if use_numba:
        newcomers_into(
            rng,
            np.ascontiguousarray(parents, dtype=np.float64),
            float(rate2),
            float(rate3),
            float(sigma_px),
            float(sigma_disparity_px),
            newcomer_constants(rig, d_min, d_max, 0),
            out,
            np.empty((0, 3)),
        )
        return out
    out[...], _ = newcomers_numpy(
        rng,
        parents,
        n,
        0,
        rig,
        rate2=rate2,
        rate3=rate3,
        sigma_px=sigma_px,
        sigma_disparity_px=sigma_disparity_px,
        d_min=d_min,
        d_max=d_max,
        margin=0,
    )
    return out
