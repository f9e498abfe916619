"""The fly algorithm's breeding operators (paper §2.1.2, §2.2): mutation, crossovers and a
generation's newcomers, one function each (selection and sharing: :mod:`flylog.fly.selection`).

Every operator takes its random numbers from the ``numpy.random.Generator`` passed in.
"""

from __future__ import annotations

import numba
import numpy as np

from flylog.fly.fusion import sonar_immigrants_into
from flylog.geometry import StereoRig
from flylog.geometry.kernels import RIG_SIZE, backproject, project


def _mutated_by(noise, xyz, rig, sigma_px, sigma_disparity_px, d_min, d_max) -> np.ndarray:
    u_left, u_right, v, _ = rig.project(xyz)
    fb = rig.fb
    measured = u_left - u_right + rig.doffs  # f·B/Z
    disparity = np.clip(measured + sigma_disparity_px * noise[:, 2], fb / d_max, fb / d_min)
    return rig.backproject(
        u_left + sigma_px * noise[:, 0], v + sigma_px * noise[:, 1], fb / disparity
    )


def _crossover2_by(lam: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return lam * a + (1.0 - lam) * b


def _crossover3_by(w: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    lam, mu = w[:, :1], w[:, 1:]
    return lam * a + mu * b + (1.0 - lam - mu) * c


def random_flies(
    rng: np.random.Generator, rig: StereoRig, n: int, *, d_min: float, d_max: float, margin: int
) -> np.ndarray:
    """(n, 3) flies whose left projections are uniform in the image (``margin`` px inside
    its border) and whose inverse depth 1/z is uniform in [1/d_max, 1/d_min] (paper §2.1.2)."""
    u = rng.uniform(margin, rig.width - 1 - margin, n)
    v = rng.uniform(margin, rig.height - 1 - margin, n)
    inv_depth = rng.uniform(1.0 / d_max, 1.0 / d_min, n)
    return rig.backproject(u, v, 1.0 / inv_depth)


# --- one generation's newcomers -----------------------------------------------------------
#
# The random stream of a generation's newcomers, in this order (both implementations draw
# exactly these numbers, so they build the same flies):
#   uniform immigrants: u (n_u), v (n_u), inverse depth (n_u), as random_flies draws them;
#   children: ``which`` (n) U[0, 1); the first parent (n), the second parent of every
#   crossover child, the third parent of every three-parent child, each ⌊U·M⌋ in child
#   order; 3 N(0, 1) per mutated child (u, v, disparity), in child order; λ per two-parent
#   child, then (λ, μ) per three-parent child (folded into the triangle), in child order.
# Only the numbers a child uses are drawn (5 per child at the default rates, not 7.3).


def _kinds(which: np.ndarray, rate2: float, rate3: float) -> tuple[np.ndarray, np.ndarray]:
    two = which < rate2
    three = (which >= rate2) & (which < rate2 + rate3)
    return two, three


def _parents_of(r: np.ndarray, m: int) -> np.ndarray:
    """⌊r·M⌋, never M (r·M may round up to M for r just below 1)."""
    return np.minimum((r * m).astype(np.int64), m - 1)


def newcomers_numpy(
    rng: np.random.Generator,
    parents: np.ndarray,
    n_children: int,
    n_uniform: int,
    rig: StereoRig,
    *,
    rate2: float,
    rate3: float,
    sigma_px: float,
    sigma_disparity_px: float,
    d_min: float,
    d_max: float,
    margin: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Reference: (children (n_children, 3), uniform immigrants (n_uniform, 3)) drawn in the
    stream order above. A child is a mutation of one parent or one of the two crossovers."""
    uniform = random_flies(rng, rig, n_uniform, d_min=d_min, d_max=d_max, margin=margin)
    m = len(parents)
    which = rng.random(n_children)
    two, three = _kinds(which, rate2, rate3)
    cross = two | three
    mutate = ~cross
    a = _parents_of(rng.random(n_children), m)
    b = np.zeros(n_children, dtype=np.int64)
    c = np.zeros(n_children, dtype=np.int64)
    b[cross] = _parents_of(rng.random(int(cross.sum())), m)
    c[three] = _parents_of(rng.random(int(three.sum())), m)
    noise = rng.standard_normal((int(mutate.sum()), 3))
    lam = rng.random((int(two.sum()), 1))
    weights = rng.random((int(three.sum()), 2))
    folded = weights.sum(axis=1) > 1.0
    weights[folded] = 1.0 - weights[folded]
    children = np.empty((n_children, 3))
    children[mutate] = _mutated_by(
        noise, parents[a[mutate]], rig, sigma_px, sigma_disparity_px, d_min, d_max
    )
    children[two] = _crossover2_by(lam, parents[a[two]], parents[b[two]])
    children[three] = _crossover3_by(
        weights, parents[a[three]], parents[b[three]], parents[c[three]]
    )
    return children, uniform


def newcomer_constants(rig: StereoRig, d_min: float, d_max: float, margin: int) -> np.ndarray:
    """What :func:`newcomers_into` needs of the rig and the search box, as one float64 array."""
    fb = rig.fb
    extra = [
        fb / d_max,
        fb / d_min,
        margin,
        rig.width - 1 - margin,
        margin,
        rig.height - 1 - margin,
        1.0 / d_max,
        1.0 / d_min,
        fb,
        rig.doffs,
    ]
    return np.concatenate([rig.constants(), np.array(extra, dtype=np.float64)])


@numba.njit(cache=True, nogil=True)
def newcomers_into(
    rng, parents, rate2, rate3, sigma_px, sigma_disparity_px, k, children, uniform
):  # pragma: no cover - compiled
    """Same flies as :func:`newcomers_numpy`, from the same draws, written into ``children``
    and ``uniform`` (``k`` from :func:`newcomer_constants`); one pass per block of draws,
    no allocation but two small scratch arrays."""
    lo, hi = k[RIG_SIZE], k[RIG_SIZE + 1]
    fb, doffs = k[RIG_SIZE + 8], k[RIG_SIZE + 9]
    # uniform immigrants: rng.uniform(low, high) is low + (high − low)·U
    n_u = uniform.shape[0]
    for j in range(3):
        low, high = k[RIG_SIZE + 2 + 2 * j], k[RIG_SIZE + 3 + 2 * j]
        for i in range(n_u):
            uniform[i, j] = low + (high - low) * rng.random()
    for i in range(n_u):
        x, y, z = backproject(k, uniform[i, 0], uniform[i, 1], 1.0 / uniform[i, 2])
        uniform[i, 0], uniform[i, 1], uniform[i, 2] = x, y, z
    n = children.shape[0]
    m = parents.shape[0]
    which = np.empty(n)
    pick = np.empty((n, 3), dtype=np.int64)
    for i in range(n):
        which[i] = rng.random()
    # The children of each kind, in child order, listed without a branch on ``which`` (fresh
    # random numbers: branches on them mispredict): the loops below then draw the same numbers
    # in the same order as a loop over every child testing its kind.
    lists = np.empty((4, n), dtype=np.int64)
    cross, two, three, mutate = lists[0], lists[1], lists[2], lists[3]
    n_cross = n_two = n_three = n_mutate = 0
    for i in range(n):
        w = which[i]
        is_cross = w < rate2 + rate3
        cross[n_cross] = i
        n_cross += is_cross
        two[n_two] = i
        n_two += w < rate2
        three[n_three] = i
        n_three += is_cross & (w >= rate2)
        mutate[n_mutate] = i
        n_mutate += not is_cross
    for i in range(n):
        pick[i, 0] = min(np.int64(rng.random() * m), m - 1)
    for t in range(n_cross):
        pick[cross[t], 1] = min(np.int64(rng.random() * m), m - 1)
    for t in range(n_three):
        pick[three[t], 2] = min(np.int64(rng.random() * m), m - 1)
    for t in range(n_mutate):
        i = mutate[t]
        a = pick[i, 0]
        u_left, u_right, v, _ = project(k, parents[a, 0], parents[a, 1], parents[a, 2])
        n_u_, n_v, n_d = rng.standard_normal(), rng.standard_normal(), rng.standard_normal()
        disparity = min(max(u_left - u_right + doffs + sigma_disparity_px * n_d, lo), hi)
        x, y, z = backproject(k, u_left + sigma_px * n_u_, v + sigma_px * n_v, fb / disparity)
        children[i, 0], children[i, 1], children[i, 2] = x, y, z
    for t in range(n_two):
        i = two[t]
        a, b = pick[i, 0], pick[i, 1]
        t2 = rng.random()
        for j in range(3):
            children[i, j] = t2 * parents[a, j] + (1.0 - t2) * parents[b, j]
    for t in range(n_three):
        i = three[t]
        a, b, c = pick[i, 0], pick[i, 1], pick[i, 2]
        lam, mu = rng.random(), rng.random()
        if lam + mu > 1.0:
            lam, mu = 1.0 - lam, 1.0 - mu
        for j in range(3):
            r = 1.0 - lam - mu
            children[i, j] = lam * parents[a, j] + mu * parents[b, j] + r * parents[c, j]


@numba.njit(cache=True, nogil=True)
def immigrants_and_children_into(
    rng, parents, br, tolerance, children, immigrants
):  # pragma: no cover - compiled
    """A generation's newcomers in one call (the Generator is passed once: numba takes ~10 µs
    to type one), with the rates, scales, constants and sonar arcs of ``br``
    (:class:`~flylog.fly.bundles.Breeding`): up to ``br.n_sonar`` sonar immigrants first in
    ``immigrants`` (:func:`~flylog.fly.fusion.sonar_immigrants_into` with ``tolerance``; none
    if no arc), then :func:`newcomers_into` with the rest of ``immigrants`` uniform. Returns
    how many came from the sonar."""
    found = 0
    if br.n_sonar > 0 and br.arcs.shape[0] > 0:
        found = sonar_immigrants_into(
            rng, br.arcs, br.half_cone, tolerance, br.arc_k, br.tries, immigrants[: br.n_sonar]
        )
    newcomers_into(
        rng,
        parents,
        br.rate2,
        br.rate3,
        br.sigma_px,
        br.sigma_d,
        br.newcomer_k,
        children,
        immigrants[found:],
    )
    return found
