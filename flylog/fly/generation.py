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
def generation_kernel(rng, lrows, rrows, channels, k, window, guard, measure, stamp,
                      xyz, fitness, vision, stale, stamp_ns, age,
                      oxyz, ofit, ovis, ostale, ostamp, oage,
                      stale_index, everyone, fuse_all, sonars, cos_half_cone, tolerance, bonus,
                      survivors, sharing, coefficient, work, radius, grid, ints, uv, counts,
                      rate2, rate3, sigma_px, sigma_d, newcomer_k, arcs, half_cone, arc_k, tries,
                      n_sonar, n_immigrants, scout_fraction, c0, c1, in_right, n_depths,
                      scout_k, candidates, candidate_index, candidate_fitness,
                      newcomers, row_scratch):  # fmt: skip  # pragma: no cover - compiled
    """A generation from ``xyz``… (scored, then selected from) into ``oxyz``…; ``everyone``
    is 0…N−1, ``stale_index`` (N,) int64 scratch, ``newcomers`` the rows after the
    survivors. ``scout_fraction`` 0: nobody scouts. Returns (evaluations, survivors,
    children, sonar immigrants)."""
    n = xyz.shape[0]
    m = 0
    for i in range(n):
        stale_index[m] = i
        m += stale[i]
    index = rows_order_into(xyz, stale_index[:m], k, lrows.shape[0], row_scratch)
    fuse = everyone if fuse_all else index
    score_into(lrows, rrows, channels, xyz, index, k, window, guard, stamp, vision, stale,
               stamp_ns, sonars, cos_half_cone, tolerance, bonus, fuse, fitness,
               measure)  # fmt: skip
    evaluations = m
    kept = select_into_kernel(fitness, coefficient, sharing, survivors, work, k, radius, grid,
                              ints, uv, counts, xyz, vision, stale, stamp_ns, age, oxyz, ofit,
                              ovis, ostale, ostamp, oage)  # fmt: skip
    n_children = n - kept - n_immigrants
    at = kept + n_children
    found = immigrants_and_children_into(
        rng, oxyz[:kept], rate2, rate3, sigma_px, sigma_d, newcomer_k, arcs, half_cone,
        tolerance, arc_k, tries, n_sonar, oxyz[kept:at], oxyz[at:],
    )  # fmt: skip
    n_scouts = round(scout_fraction * (n_immigrants - found)) if scout_fraction > 0 else 0
    if n_scouts > 0:
        r = n_scouts * n_depths
        scouts_into(rng, scout_k, c0, c1, in_right, n_depths, lrows, rrows, channels, k, window,
                    guard, measure, candidates[:r], candidate_index[:r],
                    candidate_fitness[:r], oxyz[n - n_scouts :])  # fmt: skip
        evaluations += r
    order = rows_order_into(oxyz, newcomers, k, lrows.shape[0], row_scratch)
    score_into(lrows, rrows, channels, oxyz, order, k, window, guard, stamp, ovis, ostale,
               ostamp, sonars, cos_half_cone, tolerance, bonus, order, ofit,
               measure)  # fmt: skip
    evaluations += newcomers.shape[0]
    return evaluations, kept, n_children, found


@numba.njit(cache=True, nogil=True)
def generations_kernel(count, made, rng, lrows, rrows, channels, k, window, guard, measure,
                       stamp, xyz, fitness, vision, stale, stamp_ns, age,
                       oxyz, ofit, ovis, ostale, ostamp, oage,
                       stale_index, everyone, fuse_all, sonars, cos_half_cone, tolerance, bonus,
                       survivors, sharing, coefficient, work, radius, grid, ints, uv, counts,
                       rate2, rate3, sigma_px, sigma_d, newcomer_k, arcs, half_cone, arc_k,
                       tries, n_sonar, n_immigrants, scout_fraction, c0, c1, in_right,
                       n_depths, scout_k, candidates, candidate_index, candidate_fitness,
                       newcomers, row_scratch):  # fmt: skip  # pragma: no cover - compiled
    """``count`` generations of :func:`generation_kernel` on the same inputs, one call: the
    first from ``xyz``… into ``oxyz``…, the next back, and so on (after an odd ``count`` the
    newest population is in ``oxyz``…). ``fuse_all`` applies to the first only (the next
    ones see the reading the first fused with). Row g of ``made`` (count, 4) receives
    generation g's (evaluations, survivors, children, sonar immigrants).

    Why: replay runs 10 generations a frame and most of them with no tick or record between
    them; called one by one, each return waited for the GIL that the planner's worker and
    the reading thread hold for their Python (~0.5 s of the 60 s reference replay's ~4.5 s
    on a quiet 2-core machine), and each call cost its dispatch and Python glue."""
    # ping-pong: generation g reads one set of population arrays and writes the other
    src = (xyz, fitness, vision, stale, stamp_ns, age)
    dst = (oxyz, ofit, ovis, ostale, ostamp, oage)
    for g in range(count):
        fuse = fuse_all and g == 0
        ax, af, av, ast, ats, aag = src
        bx, bf, bv, bst, bts, bag = dst
        e, kept, children, found = generation_kernel(
            rng, lrows, rrows, channels, k, window, guard, measure, stamp,
            ax, af, av, ast, ats, aag, bx, bf, bv, bst, bts, bag,
            stale_index, everyone, fuse, sonars, cos_half_cone, tolerance, bonus,
            survivors, sharing, coefficient, work, radius, grid, ints, uv, counts,
            rate2, rate3, sigma_px, sigma_d, newcomer_k, arcs, half_cone, arc_k, tries,
            n_sonar, n_immigrants, scout_fraction, c0, c1, in_right, n_depths,
            scout_k, candidates, candidate_index, candidate_fitness,
            newcomers, row_scratch,
        )  # fmt: skip
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
