"""The evolutionary operators of the fly algorithm (paper §2.1.2, §2.2), one function each.

Every operator takes its random numbers from the ``numpy.random.Generator`` passed in.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from flylog.fly.sorting import median_numba, stable_argsort_numba
from flylog.geometry import StereoRig


def survivor_indices(shared_fitness: np.ndarray, keep: int) -> np.ndarray:
    """Elitist, deterministic selection: the indices of the ``keep`` best flies, best first,
    equal fitnesses in index order (so among equal flies at the cut the lowest indices stay)."""
    score = -shared_fitness
    if keep >= len(score):
        return np.argsort(score, kind="stable")
    cut = np.partition(score, keep - 1)[keep - 1]
    better = np.flatnonzero(score < cut)
    tied = np.flatnonzero(score == cut)[: keep - len(better)]
    taken = np.concatenate([better, tied])
    taken.sort()
    return taken[np.argsort(score[taken], kind="stable")]


@numba.njit(cache=True, nogil=True)
def survivor_indices_numba(shared_fitness, keep):  # pragma: no cover - compiled
    """Same indices as :func:`survivor_indices`: the first ``keep`` of a stable sort."""
    return stable_argsort_numba(-shared_fitness)[:keep].copy()


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


@numba.njit(cache=True, nogil=True)
def shared_fitness_numba(fitness, counts, coefficient):  # pragma: no cover - compiled
    """Same values as :func:`shared_fitness`."""
    positive = fitness > 0
    out = fitness.copy()
    if not positive.any():
        return out
    step = coefficient * median_numba(fitness[positive])
    for i in range(fitness.shape[0]):
        if positive[i]:
            out[i] = fitness[i] - step * counts[i]
    return out


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


def _mutated_by(noise, xyz, rig, sigma_px, sigma_disparity_px, d_min, d_max) -> np.ndarray:
    u_left, u_right, v, _ = rig.project(xyz)
    fb = rig.focal_px * rig.baseline
    disparity = np.clip(u_left - u_right + sigma_disparity_px * noise[:, 2], fb / d_max, fb / d_min)
    return rig.backproject(
        u_left + sigma_px * noise[:, 0], v + sigma_px * noise[:, 1], fb / disparity
    )


def crossover2(rng: np.random.Generator, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Barycentric two-parent crossover: λa + (1−λ)b, λ ~ U[0, 1] (on the segment)."""
    return _crossover2_by(rng.random((len(a), 1)), a, b)


def _crossover2_by(lam: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return lam * a + (1.0 - lam) * b


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


def _crossover3_by(w: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    lam, mu = w[:, :1], w[:, 1:]
    return lam * a + mu * b + (1.0 - lam - mu) * c


@dataclass(frozen=True, slots=True)
class BreedingDraws:
    """Every random number one generation's offspring need, drawn in a fixed order so that
    both implementations of :func:`offspring` build the same children."""

    pick: np.ndarray  # (n, 3) int64: parents of each child
    which: np.ndarray  # (n,) U[0, 1): < rate2 two-parent, < rate2 + rate3 three-parent
    noise: np.ndarray  # (n, 3) N(0, 1): mutation in u, v, disparity
    lam: np.ndarray  # (n2, 1) λ of the two-parent children, in child order
    weights: np.ndarray  # (n3, 2) (λ, μ) of the three-parent children, in child order


def breeding_draws(
    rng: np.random.Generator, n_parents: int, n: int, rate2: float, rate3: float
) -> BreedingDraws:
    """The random numbers for ``n`` children of ``n_parents`` parents."""
    pick = rng.integers(0, n_parents, (n, 3))
    which = rng.random(n)
    noise = rng.standard_normal((n, 3))
    n2 = int(np.count_nonzero(which < rate2))
    n3 = int(np.count_nonzero(which < rate2 + rate3)) - n2
    lam = rng.random((n2, 1)) if n2 else np.empty((0, 1))
    weights = _triangle_weights(rng, n3) if n3 else np.empty((0, 2))
    return BreedingDraws(pick, which, noise, lam, weights)


def children_numpy(
    parents: np.ndarray,
    draws: BreedingDraws,
    rig: StereoRig,
    *,
    rate2: float,
    rate3: float,
    sigma_px: float,
    sigma_disparity_px: float,
    d_min: float,
    d_max: float,
) -> np.ndarray:
    """Reference: the children ``draws`` describe (mutation of the first parent, or one of
    the two crossovers)."""
    first = parents[draws.pick[:, 0]]
    out = _mutated_by(draws.noise, first, rig, sigma_px, sigma_disparity_px, d_min, d_max)
    two = draws.which < rate2
    if two.any():
        out[two] = _crossover2_by(draws.lam, first[two], parents[draws.pick[two, 1]])
    three = (draws.which >= rate2) & (draws.which < rate2 + rate3)
    if three.any():
        out[three] = _crossover3_by(
            draws.weights, first[three], parents[draws.pick[three, 1]],
            parents[draws.pick[three, 2]],
        )  # fmt: skip
    return out


@numba.njit(cache=True, nogil=True)
def _children_kernel(parents, pick, which, noise, lam, weights, rate2, rate3, k, sigmas, out):
    """One pass over the children; ``k`` = (f, cx, cy, b/2, mount x, mount height, lowest
    and highest disparity), ``sigmas`` = (σ_px, σ_disparity). Same arithmetic, in the same
    order, as the numpy operators, so the results are bit-identical."""
    f, cx, cy, half_b, mount_x, mount_h, lo, hi = k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7]
    fb = f * (2.0 * half_b)
    n2 = 0
    n3 = 0
    for i in range(which.shape[0]):
        a = pick[i, 0]
        if which[i] < rate2:
            b = pick[i, 1]
            t = lam[n2, 0]
            n2 += 1
            for j in range(3):
                out[i, j] = t * parents[a, j] + (1.0 - t) * parents[b, j]
        elif which[i] < rate2 + rate3:
            b, c = pick[i, 1], pick[i, 2]
            t, m = weights[n3, 0], weights[n3, 1]
            n3 += 1
            for j in range(3):
                out[i, j] = t * parents[a, j] + m * parents[b, j] + (1.0 - t - m) * parents[c, j]
        else:
            depth = parents[a, 0] - mount_x
            safe = depth if depth > 1e-9 else 1e-9
            u_left = cx - f * (parents[a, 1] - half_b) / safe
            u_right = cx - f * (parents[a, 1] + half_b) / safe
            v = cy - f * (parents[a, 2] - mount_h) / safe
            disparity = min(max(u_left - u_right + sigmas[1] * noise[i, 2], lo), hi)
            z = fb / disparity
            u = u_left + sigmas[0] * noise[i, 0]
            vv = v + sigmas[0] * noise[i, 1]
            out[i, 0] = mount_x + z
            out[i, 1] = half_b - (u - cx) * z / f
            out[i, 2] = mount_h - (vv - cy) * z / f


def children_numba(
    parents: np.ndarray,
    draws: BreedingDraws,
    rig: StereoRig,
    *,
    rate2: float,
    rate3: float,
    sigma_px: float,
    sigma_disparity_px: float,
    d_min: float,
    d_max: float,
) -> np.ndarray:
    """Same children as :func:`children_numpy`, in one compiled pass."""
    fb = rig.focal_px * rig.baseline
    k = np.array(
        [rig.focal_px, rig.cx, rig.cy, rig.baseline / 2.0, rig.mount_x, rig.mount_height,
         fb / d_max, fb / d_min],
        dtype=np.float64,
    )  # fmt: skip
    out = np.empty((len(draws.which), 3))
    _children_kernel(
        np.ascontiguousarray(parents, dtype=np.float64), draws.pick, draws.which, draws.noise,
        draws.lam, draws.weights, float(rate2), float(rate3), k,
        np.array([sigma_px, sigma_disparity_px], dtype=np.float64), out,
    )  # fmt: skip
    return out


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
) -> np.ndarray:
    """``n`` children of ``parents`` (M, 3): a share ``rate2`` by two-parent crossover,
    ``rate3`` by three-parent crossover, the rest by mutation of one parent. Parents are
    drawn uniformly (with replacement) among the survivors."""
    draws = breeding_draws(rng, len(parents), n, rate2, rate3)
    build = children_numba if use_numba else children_numpy
    return build(
        parents, draws, rig, rate2=rate2, rate3=rate3, sigma_px=sigma_px,
        sigma_disparity_px=sigma_disparity_px, d_min=d_min, d_max=d_max,
    )  # fmt: skip
