"""The evolutionary operators of the fly algorithm (paper §2.1.2, §2.2), one function each.

Every operator takes its random numbers from the ``numpy.random.Generator`` passed in.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from flylog.fly.sorting import median_in_place, smallest_stable_numba
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
    return smallest_stable_numba(-shared_fitness, keep)


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


# The grid never has more than this many cells per valid fly (its cells grow instead), so its
# buffer is O(N) whatever the spread of the points.
_CELLS_PER_FLY = 4


def grid_buffer_size(n: int) -> int:
    """Cells' buffer length :func:`neighbour_counts_into` needs for ``n`` flies."""
    return 3 * _CELLS_PER_FLY * n + 2


@numba.njit(cache=True, nogil=True)
def neighbour_counts_into(u, v, valid, radius, starts, order, uv, near, counts):  # pragma: no cover
    """Same counts as :func:`neighbour_counts_numpy`, written into ``counts``, through a grid of
    cells no smaller than R. Flies are counting-sorted by cell (row-major; ``starts`` at
    least :func:`grid_buffer_size` long; ``order``, ``uv`` (N, 2), ``near`` at least N), so the
    rest of a fly's cell and the cell on its right are one contiguous run of sorted flies, and
    the 3 cells below it another; each pair is tested once, from its first fly."""
    n = u.shape[0]
    umin, vmin, umax, vmax = np.inf, np.inf, -np.inf, -np.inf
    n_valid = 0
    for i in range(n):
        counts[i] = 0
        if valid[i]:
            near[n_valid] = 0
            n_valid += 1
            umin, umax = min(umin, u[i]), max(umax, u[i])
            vmin, vmax = min(vmin, v[i]), max(vmax, v[i])
    if n_valid == 0:
        return
    # A hair above R: two points R apart can never land two cells apart through rounding.
    cell = max(radius * (1.0 + 1e-6), 1.0)
    limit = _CELLS_PER_FLY * n_valid
    w, h = umax - umin, vmax - vmin
    if (w / cell + 1.0) * (h / cell + 1.0) > limit:
        # so that gw·gh ≤ area/cell² + (w + h)/cell + 1 ≤ 3·limit + 1
        cell = max(cell, np.sqrt(w * h / limit), w / limit, h / limit)
    inv = 1.0 / cell
    gw = int(w * inv) + 1
    gh = int(h * inv) + 1
    n_cells = gw * gh
    for c in range(n_cells + 2):
        starts[c] = 0
    for i in range(n):
        if valid[i]:
            c = int((v[i] - vmin) * inv) * gw + int((u[i] - umin) * inv)
            starts[c + 2] += 1
    total = 0
    for c in range(2, n_cells + 2):
        total += starts[c]  # a running sum in a register: no store-to-load chain
        starts[c] = total
    # scatter through starts[c + 1], which ends as the end of cell c (= the start of c + 1)
    for i in range(n):
        if valid[i]:
            c = int((v[i] - vmin) * inv) * gw + int((u[i] - umin) * inv)
            t = starts[c + 1]
            uv[t, 0] = u[i]
            uv[t, 1] = v[i]
            order[t] = i
            starts[c + 1] = t + 1
    r2 = radius * radius
    for row in range(gh):
        for gu in range(gw):
            c = row * gw + gu
            if starts[c] == starts[c + 1]:
                continue
            right = starts[c + 2] if gu + 1 < gw else starts[c + 1]
            below_lo = below_hi = 0
            if row + 1 < gh:
                below_lo = starts[c + gw - 1] if gu > 0 else starts[c + gw]
                below_hi = starts[c + gw + 2] if gu + 1 < gw else starts[c + gw + 1]
            for a in range(starts[c], starts[c + 1]):
                ua, va = uv[a, 0], uv[a, 1]
                total = 0
                for b in range(a + 1, right):
                    du = ua - uv[b, 0]
                    dv = va - uv[b, 1]
                    hit = du * du + dv * dv <= r2
                    total += hit
                    near[b] += hit
                for b in range(below_lo, below_hi):
                    du = ua - uv[b, 0]
                    dv = va - uv[b, 1]
                    hit = du * du + dv * dv <= r2
                    total += hit
                    near[b] += hit
                near[a] += total
    for t in range(n_valid):
        counts[order[t]] = near[t]


class NeighbourCounter:
    """:func:`neighbour_counts_into` with buffers kept between calls (the engine counts
    every generation; the grid's buffers are not reallocated each time)."""

    def __init__(self) -> None:
        self._n = -1
        self._starts = np.empty(0, dtype=np.int64)
        self._order = np.empty(0, dtype=np.int64)
        self._uv = np.empty((0, 2))
        self._near = np.empty(0, dtype=np.int64)

    def __call__(
        self, u: np.ndarray, v: np.ndarray, valid: np.ndarray, radius: float
    ) -> np.ndarray:
        """(N,) int64 neighbour counts (a new array)."""
        n = len(u)
        if n != self._n:
            self._n = n
            self._starts = np.empty(grid_buffer_size(n), dtype=np.int64)
            self._order = np.empty(n, dtype=np.int64)
            self._uv = np.empty((n, 2))
            self._near = np.empty(n, dtype=np.int64)
        counts = np.empty(n, dtype=np.int64)
        neighbour_counts_into(
            u, v, valid, float(radius), self._starts, self._order, self._uv, self._near, counts
        )
        return counts


def neighbour_counts_numba(
    u: np.ndarray, v: np.ndarray, valid: np.ndarray, radius: float
) -> np.ndarray:
    """Same counts as :func:`neighbour_counts_numpy` (compiled grid, fresh buffers)."""
    return NeighbourCounter()(u, v, valid, radius)


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
    out = fitness.copy()
    positive = fitness[fitness > 0]
    if positive.shape[0] == 0:
        return out
    step = coefficient * median_in_place(positive)
    for i in range(fitness.shape[0]):
        if fitness[i] > 0:
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
    out: np.ndarray | None = None,
) -> np.ndarray:
    """Same children as :func:`children_numpy`, in one compiled pass (into ``out`` if given,
    a C-contiguous (n, 3) float64 array)."""
    fb = rig.focal_px * rig.baseline
    k = np.array(
        [rig.focal_px, rig.cx, rig.cy, rig.baseline / 2.0, rig.mount_x, rig.mount_height,
         fb / d_max, fb / d_min],
        dtype=np.float64,
    )  # fmt: skip
    if out is None:
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
    out: np.ndarray | None = None,
) -> np.ndarray:
    """``n`` children of ``parents`` (M, 3): a share ``rate2`` by two-parent crossover,
    ``rate3`` by three-parent crossover, the rest by mutation of one parent. Parents are
    drawn uniformly (with replacement) among the survivors. Written into ``out`` (n, 3) when
    given (C-contiguous float64 for the compiled path), which is returned."""
    draws = breeding_draws(rng, len(parents), n, rate2, rate3)
    options = dict(
        rate2=rate2, rate3=rate3, sigma_px=sigma_px, sigma_disparity_px=sigma_disparity_px,
        d_min=d_min, d_max=d_max,
    )  # fmt: skip
    if use_numba:
        return children_numba(parents, draws, rig, **options, out=out)
    children = children_numpy(parents, draws, rig, **options)
    if out is None:
        return children
    out[...] = children
    return out
