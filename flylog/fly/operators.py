"""The evolutionary operators of the fly algorithm (paper §2.1.2, §2.2), one function each.

Every operator takes its random numbers from the ``numpy.random.Generator`` passed in.
"""

from __future__ import annotations

import numba
import numpy as np

from flylog.geometry import StereoRig


def survivor_indices(shared_fitness: np.ndarray, keep: int) -> np.ndarray:
    """Elitist, deterministic selection: the indices of the ``keep`` best flies, best first
    (equal fitnesses in index order; which of several equal flies at the cut are kept is
    deterministic but unspecified)."""
    score = -shared_fitness
    best = np.argpartition(score, keep - 1)[:keep] if keep < len(score) else np.arange(len(score))
    return best[np.lexsort((best, score[best]))]


def neighbour_counts_numpy(
    u: np.ndarray, v: np.ndarray, valid: np.ndarray, radius: float
) -> np.ndarray:
    """Reference: for each valid fly, how many other valid flies project within ``radius``
    px of it in the left image (O(N²); invalid flies count 0)."""
    du = u[:, None] - u[None, :]
    dv = v[:, None] - v[None, :]
    near = (du * du + dv * dv <= radius * radius) & valid[:, None] & valid[None, :]
    np.fill_diagonal(near, False)
    return near.sum(axis=1).astype(np.int64)


@numba.njit(cache=True, nogil=True)
def neighbour_counts_numba(u, v, valid, radius):  # pragma: no cover - compiled
    """Same counts as :func:`neighbour_counts_numpy`, through a grid hash of cell size ≥ R:
    flies are counting-sorted by cell, so the 3 cells of each neighbouring row are one
    contiguous run of sorted coordinates."""
    n = u.shape[0]
    counts = np.zeros(n, dtype=np.int64)
    cell = max(radius, 1.0)
    r2 = radius * radius
    umin, vmin, umax, vmax = np.inf, np.inf, -np.inf, -np.inf
    for i in range(n):
        if valid[i]:
            umin, umax = min(umin, u[i]), max(umax, u[i])
            vmin, vmax = min(vmin, v[i]), max(vmax, v[i])
    if not umin <= umax:
        return counts
    gw = int((umax - umin) / cell) + 1
    gh = int((vmax - vmin) / cell) + 1
    gu_of = np.empty(n, dtype=np.int64)
    gv_of = np.empty(n, dtype=np.int64)
    starts = np.zeros(gw * gh + 1, dtype=np.int64)
    for i in range(n):
        if valid[i]:
            gu_of[i] = int((u[i] - umin) / cell)
            gv_of[i] = int((v[i] - vmin) / cell)
            starts[gv_of[i] * gw + gu_of[i] + 1] += 1
    for c in range(gw * gh):
        starts[c + 1] += starts[c]
    fill = starts[:-1].copy()
    su = np.empty(starts[-1])
    sv = np.empty(starts[-1])
    for i in range(n):
        if valid[i]:
            c = gv_of[i] * gw + gu_of[i]
            su[fill[c]] = u[i]
            sv[fill[c]] = v[i]
            fill[c] += 1
    for i in range(n):
        if not valid[i]:
            continue
        lo_u, hi_u = max(gu_of[i] - 1, 0), min(gu_of[i] + 1, gw - 1)
        total = -1  # the fly itself is in range
        for gv in range(max(gv_of[i] - 1, 0), min(gv_of[i] + 2, gh)):
            for t in range(starts[gv * gw + lo_u], starts[gv * gw + hi_u + 1]):
                du = u[i] - su[t]
                dv = v[i] - sv[t]
                if du * du + dv * dv <= r2:
                    total += 1
        counts[i] = total
    return counts


def shared_fitness(fitness: np.ndarray, counts: np.ndarray, coefficient: float) -> np.ndarray:
    """2-D sharing: fitness − K·n·f̃, with f̃ the median of the positive fitnesses, so that K
    is dimensionless whatever the images' contrast. Non-positive fitnesses are left alone."""
    positive = fitness > 0
    if not positive.any():
        return fitness.copy()
    scale = float(np.median(fitness[positive]))
    return np.where(positive, fitness - coefficient * scale * counts, fitness)


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
    u_left, u_right, v, _ = rig.project(xyz)
    noise = rng.standard_normal((len(xyz), 3))
    fb = rig.focal_px * rig.baseline
    disparity = np.clip(u_left - u_right + sigma_disparity_px * noise[:, 2], fb / d_max, fb / d_min)
    return rig.backproject(
        u_left + sigma_px * noise[:, 0], v + sigma_px * noise[:, 1], fb / disparity
    )


def crossover2(rng: np.random.Generator, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Barycentric two-parent crossover: λa + (1−λ)b, λ ~ U[0, 1] (on the segment)."""
    lam = rng.random((len(a), 1))
    return lam * a + (1.0 - lam) * b


def crossover3(rng: np.random.Generator, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Barycentric three-parent crossover: λa + μb + (1−λ−μ)c with (λ, μ) uniform in the
    triangle λ, μ ≥ 0, λ + μ ≤ 1 (inside the parents' triangle)."""
    w = rng.random((len(a), 2))
    folded = w.sum(axis=1) > 1.0
    w[folded] = 1.0 - w[folded]
    lam, mu = w[:, :1], w[:, 1:]
    return lam * a + mu * b + (1.0 - lam - mu) * c


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
) -> np.ndarray:
    """``n`` children of ``parents`` (M, 3): a share ``rate2`` by two-parent crossover,
    ``rate3`` by three-parent crossover, the rest by mutation of one parent. Parents are
    drawn uniformly (with replacement) among the survivors."""
    pick = rng.integers(0, len(parents), (n, 3))
    which = rng.random(n)
    first = parents[pick[:, 0]]
    children = mutated(
        rng,
        first,
        rig,
        sigma_px=sigma_px,
        sigma_disparity_px=sigma_disparity_px,
        d_min=d_min,
        d_max=d_max,
    )
    two = which < rate2
    if two.any():
        children[two] = crossover2(rng, first[two], parents[pick[two, 1]])
    three = (which >= rate2) & (which < rate2 + rate3)
    if three.any():
        children[three] = crossover3(
            rng, first[three], parents[pick[three, 1]], parents[pick[three, 2]]
        )
    return children
