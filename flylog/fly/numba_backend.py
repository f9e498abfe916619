"""The fly engine's compiled back-end (:class:`~flylog.fly.engine.FlyEngine`, ``backend =
"numba"``): any number of generations in one compiled call
(:func:`~flylog.fly.generation.generations_kernel`: the kernels of the numpy back-end's
steps, in the same order, on the same random numbers), after the parallel fitness kernel
when enough flies are stale to make it pay."""

from __future__ import annotations

import numpy as np

from flylog.fly.bundles import Breeding, Fusion, Scratch, Selection
from flylog.fly.fitness import PARALLEL_MIN_EVALUATIONS, fitness_into
from flylog.fly.fusion import arc_constants, score_into
from flylog.fly.generation import generations_kernel
from flylog.fly.neighbours import NeighbourCounter
from flylog.fly.operators import newcomer_constants
from flylog.fly.state import SONAR_TRIES, EngineState
from flylog.fly.stats import GenerationStats
from flylog.geometry import Pose2D
from flylog.geometry.proprioception import move_by_odometry


class NumbaBackend:
    """Generations of an :class:`~flylog.fly.state.EngineState` by the compiled kernels."""

    def __init__(self, state: EngineState) -> None:
        self._state = state
        cfg, rig = state.config, state.rig
        self._counter = NeighbourCounter()
        self._work = np.empty(2 * cfg.flies)  # selection's scratch
        self._newcomer_k = newcomer_constants(rig, cfg.d_min, cfg.d_max, state.margin)
        self._arc_k = arc_constants(rig, state.margin)
        self._no_sonars = np.empty((0, 5))
        stale_index = np.empty(cfg.flies, dtype=np.int64)
        row_scratch = np.empty((3, max(cfg.flies, rig.height + 2)), dtype=np.int64)
        self._scratch = Scratch(
            stale_index=stale_index,
            everyone=state.everyone,
            newcomers=state.newcomers,
            row_scratch=row_scratch,
        )

    def move(self, increment: Pose2D) -> None:
        """Every fly moved by the inverse of the robot's motion ``increment``, in place."""
        move_by_odometry(self._state.pop.xyz, increment)

    def steps(self, count: int) -> list[GenerationStats]:
        """``count`` generations on the newest data, in one compiled call."""
        st, cfg = self._state, self._state.config
        im = st.images
        assert im is not None  # set by the first pair
        pop, nxt = st.pop, st.spare
        reading = st.sonar if st.fuse_sonar else None
        fuse_all = reading is not st.fused_with
        st.fused_with = reading
        sonars = self._no_sonars if reading is None else st.sonars
        fusion = Fusion(
            sonars=sonars,
            cos_half_cone=float(st.cos_half_cone),
            tolerance=float(cfg.sonar_tolerance),
            bonus=float(cfg.sonar_bonus),
        )
        evaluations = 0
        if cfg.flies >= PARALLEL_MIN_EVALUATIONS and pop.stale.any():
            stale = np.flatnonzero(pop.stale)
            if len(stale) >= PARALLEL_MIN_EVALUATIONS:
                evaluations = len(stale)
                fitness_into(im, st.measure, pop.xyz, stale, pop.vision)
                pop.stale[stale] = False
                pop.stamp_ns[stale] = st.stamp_ns
                if not fuse_all:  # the kernel fuses only the flies it scores: these too
                    score_into(im, st.measure, fusion, pop.flies(), stale[:0], stale)
        made = np.empty((count, 4), dtype=np.int64)
        generations_kernel(
            count,
            made,
            st.rng,
            im,
            st.measure,
            pop.flies(),
            nxt.flies(),
            fuse_all,
            fusion,
            self._selection(),
            self._breeding(),
            st.scouts.bundle(st.n_immigrants),
            self._scratch,
        )
        if count % 2:
            st.swap()
        made[0, 0] += evaluations
        first = st.generation + 1
        st.generation += count
        return [
            GenerationStats(
                generation=first + g,
                evaluations=int(e),
                image_stamp_ns=st.stamp_ns,
                survivors=int(kept),
                offspring=int(children),
                immigrants=st.n_immigrants,
                sonar_immigrants=int(found),
            )
            for g, (e, kept, children, found) in enumerate(made.tolist())
        ]

    def _selection(self) -> Selection:
        st = self._state
        grid, ints, floats = self._counter.scratch(st.config.flies)
        return Selection(
            survivors=st.survivors,
            sharing=st.sharing,
            coefficient=float(st.config.sharing_coefficient),
            work=self._work,
            radius=st.radius,
            grid=grid,
            ints=ints,
            floats=floats,
            counts=self._counter.counts,
        )

    def _breeding(self) -> Breeding:
        st = self._state
        rate2, rate3, sigma_px, sigma_d = st.breeding
        return Breeding(
            rate2=rate2,
            rate3=rate3,
            sigma_px=sigma_px,
            sigma_d=sigma_d,
            newcomer_k=self._newcomer_k,
            arcs=st.arcs,
            half_cone=0.0 if st.sonar is None else float(st.sonar.half_cone),
            arc_k=self._arc_k,
            tries=SONAR_TRIES,
            n_sonar=st.n_sonar(),
            n_immigrants=st.n_immigrants,
        )
