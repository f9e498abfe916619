"""One generation of the compiled engine in one call (:meth:`FlyEngine.step`, numba backend).

Why one call: at ~150 generations a second of replay, four or five compiled calls per
generation with Python between them cost ~5 % of the engine's thread in dispatch (numba types
a ``numpy.random.Generator`` in ~10 µs, twice while scouting) and glue. The kernels run in the
numpy backend's order on the same arrays, drawing the same random numbers: the population is
the one the numpy backend makes (tests compare them).
Each step is the function named, see there:

1. vision fitness of the stale flies, fused fitness of those (of every fly when asked),
   :func:`~flylog.fly.fusion.score_into`;
2. selection into the other population, with sharing's neighbour counts or without,
   :func:`~flylog.fly.population.select_into_kernel`;
3. sonar immigrants, children and uniform immigrants,
   :func:`~flylog.fly.operators.immigrants_and_children_into`;
4. scouts in place of the last uniform immigrants while turning,
   :func:`~flylog.fly.scouts.scouts_into` (their count as :meth:`Scouting.count` gives it);
5. the newcomers' fitness, :func:`~flylog.fly.fusion.score_into` again.

Flies are scored in the order of their image rows (:func:`rows_order_into`), not in index
order: a fly's fitness does not depend on the others', and neighbouring windows then share
the caches.
"""

from __future__ import annotations

import numba

from flylog.fly.fusion import score_into
from flylog.fly.operators import immigrants_and_children_into
from flylog.fly.population import select_into_kernel
from flylog.fly.scouts import scouts_into
from flylog.geometry.kernels import row_of


@numba.njit(cache=True, nogil=True)
def generation_kernel(
    rng, im, measure, a, b, fuse_all, fu, se, br, sc, scratch
):  # pragma: no cover - compiled
    """A generation from the flies ``a`` (scored, then selected from) into ``b``, with the
    bundles of :mod:`flylog.fly.bundles` (``im`` :class:`Images`, ``fu`` :class:`Fusion`,
    ``se`` :class:`Selection`, ``br`` :class:`Breeding`, ``sc`` :class:`Scouting`,
    ``scratch`` :class:`Scratch`) and the similarity ``measure``. ``sc.fraction`` 0: nobody
    scouts. Returns (evaluations, survivors, children, sonar immigrants)."""
    n = a.xyz.shape[0]
    height = im.lrows.shape[0]
    m = 0
    for i in range(n):
        scratch.stale_index[m] = i
        m += a.stale[i]
    index = rows_order_into(a.xyz, scratch.stale_index[:m], im.k, height, scratch.row_scratch)
    fuse = scratch.everyone if fuse_all else index
    score_into(im, measure, fu, a, index, fuse)
    evaluations = m
    kept = select_into_kernel(se, im.k, a, b)
    n_children = n - kept - br.n_immigrants
    at = kept + n_children
    found = immigrants_and_children_into(
        rng, b.xyz[:kept], br, fu.tolerance, b.xyz[kept:at], b.xyz[at:]
    )
    n_scouts = round(sc.fraction * (br.n_immigrants - found)) if sc.fraction > 0 else 0
    if n_scouts > 0:
        scouts_into(rng, sc, n_scouts, im, measure, b.xyz[n - n_scouts :])
        evaluations += n_scouts * sc.n_depths
    order = rows_order_into(b.xyz, scratch.newcomers, im.k, height, scratch.row_scratch)
    score_into(im, measure, fu, b, order, order)
    evaluations += scratch.newcomers.shape[0]
    return evaluations, kept, n_children, found


@numba.njit(cache=True, nogil=True)
def generations_kernel(
    count, made, rng, im, measure, a, b, fuse_all, fu, se, br, sc, scratch
):  # pragma: no cover - compiled
    """``count`` generations of :func:`generation_kernel` on the same inputs, one call: the
    first from the flies ``a`` into ``b``, the next back, and so on (after an odd ``count``
    the newest population is in ``b``). ``fuse_all`` applies to the first only (the next
    ones see the reading the first fused with). Row g of ``made`` (count, 4) receives
    generation g's (evaluations, survivors, children, sonar immigrants).

    Why: replay runs 10 generations a frame and most of them with no tick or record between
    them; called one by one, each return waited for the GIL that the planner's worker and
    the reading thread hold for their Python (~0.5 s of the 60 s reference replay's ~4.5 s
    on a quiet 2-core machine), and each call cost its dispatch and Python glue."""
    src, dst = a, b  # ping-pong: generation g reads one population and writes the other
    for g in range(count):
        e, kept, children, found = generation_kernel(
            rng, im, measure, src, dst, fuse_all and g == 0, fu, se, br, sc, scratch
        )
        src, dst = dst, src
        made[g, 0] = e
        made[g, 1] = kept
        made[g, 2] = children
        made[g, 3] = found


@numba.njit(cache=True, nogil=True, error_model="numpy")
def rows_order_into(xyz, index, k, height, scratch):  # pragma: no cover - compiled
    """The flies ``index`` of ``xyz`` in the order of the image row their left projection
    falls in (a stable counting sort; flies off the image first), as a view of
    ``scratch[2]``: scoring flies in this order reads the images row band by row band, their
    windows overlapping in the caches (~12 % faster for a generation's newcomers, the sort
    included). ``scratch`` is (3, ≥ max(len(index), height + 2)) integer."""
    m = index.shape[0]
    bins = height + 2
    counts, row, out = scratch[0, :bins], scratch[1], scratch[2]
    counts[:] = 0
    for t in range(m):
        i = index[t]
        v = row_of(k, xyz[i, 0], xyz[i, 1], xyz[i, 2])
        r = int(v) + 1 if 0.0 <= v < height else 0
        row[t] = r
        counts[r] += 1
    total = 0
    for r in range(bins):
        total, counts[r] = total + counts[r], total
    for t in range(m):
        r = row[t]
        out[counts[r]] = index[t]
        counts[r] += 1
    return out[:m]
