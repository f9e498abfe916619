"""The fly engine's numpy back-end: one generation at a time with the numpy references of
every kernel (:class:`~flylog.fly.engine.FlyEngine`, ``backend = "numpy"``). It makes the
population the compiled back-end makes, drawing the same random numbers in the same order
(tests compare them)."""

from __future__ import annotations

import numpy as np

from flylog.fly.fitness import INVALID_FITNESS, fitness_numpy
from flylog.fly.fusion import sonar_fused, sonar_immigrants
from flylog.fly.neighbours import neighbour_counts_numpy
from flylog.fly.operators import newcomers_numpy
from flylog.fly.selection import shared_fitness, survivor_indices
from flylog.fly.state import SONAR_TRIES, EngineState
from flylog.fly.stats import GenerationStats
from flylog.geometry import Pose2D
from flylog.geometry.proprioception import moved_by_odometry
from flylog.sensors import SonarReading


class NumpyBackend:
    """Generations of an :class:`~flylog.fly.state.EngineState` by the numpy references."""

    def __init__(self, state: EngineState) -> None:
        self._state = state

    def move(self, increment: Pose2D) -> None:
        """Every fly moved by the inverse of the robot's motion ``increment``."""
        self._state.pop.xyz = moved_by_odometry(self._state.pop.xyz, increment)

    def steps(self, count: int) -> list[GenerationStats]:
        """``count`` generations on the newest data."""
        return [self._step() for _ in range(count)]

    def _step(self) -> GenerationStats:
        st, cfg = self._state, self._state.config
        pop = st.pop
        # after a step every fly is evaluated; new images make them all stale
        if pop.stale.all():
            stale = st.everyone
        else:
            stale = np.flatnonzero(pop.stale) if pop.stale.any() else st.everyone[:0]
        evaluations = self._score(stale)
        nxt = st.spare
        n_immigrants = st.n_immigrants
        # random numbers in this order: sonar arcs, uniform immigrants, breeding
        ranked = pop.fitness
        if st.sharing:
            u_left, _, v, _ = st.rig.project(pop.xyz)
            valid = pop.fitness > INVALID_FITNESS
            counts = neighbour_counts_numpy(u_left, v, valid, st.radius)
            ranked = shared_fitness(pop.fitness, counts, cfg.sharing_coefficient)
        keep = survivor_indices(ranked, st.survivors)
        k = len(keep)
        n_children = cfg.flies - k - n_immigrants
        from_sonar = self._sonar_immigrants()
        n_sonar = len(from_sonar)
        rate2, rate3, sigma_px, sigma_d = st.breeding
        children, uniform = newcomers_numpy(
            st.rng,
            pop.xyz[keep],
            n_children,
            n_immigrants - n_sonar,
            st.rig,
            rate2=rate2,
            rate3=rate3,
            sigma_px=sigma_px,
            sigma_disparity_px=sigma_d,
            d_min=cfg.d_min,
            d_max=cfg.d_max,
            margin=st.margin,
        )
        pop.survivors_then(keep, np.concatenate([children, from_sonar, uniform]), out=nxt)
        # Scouting immigrants (flylog.fly.scouts): while turning, the last uniform immigrants
        # move to where new content enters the view; their candidates' evaluations are
        # charged here, the chosen flies are scored with the other newcomers.
        assert st.left is not None and st.right is not None  # set by the first pair
        evaluations += st.scouts.place(
            st.rng, nxt.xyz, n_immigrants, n_sonar, st.left, st.right, readout=st.readout
        )
        st.swap()
        evaluations += self._score(st.newcomers)
        st.generation += 1
        return GenerationStats(
            generation=st.generation,
            evaluations=evaluations,
            image_stamp_ns=st.stamp_ns,
            survivors=k,
            offspring=n_children,
            immigrants=n_immigrants,
            sonar_immigrants=n_sonar,
        )

    def _score(self, index: np.ndarray) -> int:
        """Vision fitness of the flies ``index`` (all stale) on the newest images, then the
        fused fitness of those (of every fly if the reading changed or the flies moved).
        Returns how many were evaluated."""
        st = self._state
        reading = st.sonar if st.fuse_sonar else None
        fuse = index
        if reading is not st.fused_with:
            fuse, st.fused_with = st.everyone, reading
        self._score_flies(index, fuse, reading)
        return len(index)

    def _score_flies(
        self, index: np.ndarray, fuse: np.ndarray, reading: SonarReading | None
    ) -> None:
        st, cfg = self._state, self._state.config
        pop = st.pop
        assert st.left is not None and st.right is not None
        if len(index):
            pop.vision[index] = fitness_numpy(
                st.left,
                st.right,
                pop.xyz[index],
                st.rig,
                cfg.window,
                cfg.guard,
                gradient=cfg.gradient,
                similarity=cfg.similarity,
                subpixel=cfg.subpixel,
                readout=st.readout,
            )
            pop.stale[index] = False
            pop.stamp_ns[index] = st.stamp_ns
        if len(fuse) == 0:
            return
        if reading is None or len(st.sonars) == 0:
            pop.fitness[fuse] = pop.vision[fuse]
        else:
            pop.fitness[fuse] = sonar_fused(
                pop.vision[fuse],
                pop.xyz[fuse],
                reading,
                bonus=cfg.sonar_bonus,
                tolerance=cfg.sonar_tolerance,
                use_numba=False,
            )

    def _sonar_immigrants(self) -> np.ndarray:
        """This generation's sonar immigrants (the compiled back-end draws them with the
        rest)."""
        st = self._state
        n = st.n_sonar()
        if n == 0:
            return np.empty((0, 3))
        assert st.sonar is not None
        return sonar_immigrants(
            st.rng,
            st.sonar,
            n,
            st.rig,
            tolerance=st.config.sonar_tolerance,
            margin=st.margin,
            tries=SONAR_TRIES,
        )
