"""Scouting immigrants: while the robot turns, a share of the uniform immigrants go where new
scene content enters the view, each at the best of K candidate depths (it shortens the
detection latency of what comes into view).

Turning on the spot, the scene enters the left image at one edge (turning left, at the left
edge; right, at the right edge), a strip as wide as the turn sweeps. Uniform immigrants land
on that strip rarely and at the right depth more rarely still, and the children of flies
elsewhere seldom move there, so a new obstacle waits frames for flies. A scout is a pixel
drawn uniformly in the strip with K disparities spread over the searched range (one per
K-th of it, stratified); the best of the K by vision fitness enters the population. Every
candidate evaluation is returned to the caller, which charges it to the compute budget.

The strip is what the odometry's yaw over the last ``scout_strip_frames`` image intervals
brought into view (a pure rotation about the robot's vertical axis; the cameras' offset
from it, and a tilted or rolled camera's slant of the image edge, are neglected: the strip
is a band of columns, from the principal point and doffs). Driving straight, nothing enters
at an edge (the view expands from its centre), so below ``scout_min_shift`` pixels of edge
motion per frame nobody scouts and the immigrants stay uniform.

The random stream of one call, both implementations: per scout, U for the column, U for the
row, then K U for the offsets of its disparities in their K-ths.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from flylog.fly.bundles import Scouting as ScoutBundle
from flylog.fly.config import EngineConfig
from flylog.fly.fitness import fitness_numpy, fitness_serial
from flylog.fly.operators import newcomer_constants
from flylog.geometry import Pose2D, StereoRig
from flylog.geometry.kernels import CX, CY, FOCAL, LEFT, RIG_SIZE, ROWS, backproject
from flylog.geometry.kernels import seen_at_stamp as seen_at_stamp_kernel
from flylog.geometry.rolling import STILL, is_still, row_motion, seen_at_stamp


def entering_strip(
    rig: StereoRig, yaw: float, margin: int, min_width: float = 1.0
) -> tuple[float, float, bool]:
    """(c0, c1, in_right): the columns [c0, c1] (``margin`` px inside the border) where a
    turn by ``yaw`` rad (positive: to the left) brought content into view, at least
    ``min_width`` px wide; c1 < c0 for no turn. Turning right, content enters both images
    at their right edge: the strip is in the left image. Turning left, it enters at the left
    edge, where the left image's pixels are not yet in the right one: the strip is in the
    right image (``in_right``), the left column being c + disparity. A bearing φ (left
    positive) is at column cx − f·tan φ."""
    if yaw == 0.0:
        return 0.0, -1.0, False
    f, cx = rig.focal_px, rig.cx
    lo, hi = float(margin), float(rig.width - 1 - margin)
    if yaw > 0:
        edge = math.atan2(cx, f)
        inner = cx - f * math.tan(max(edge - yaw, -edge))
        return lo, min(hi, max(inner, lo + min_width)), True
    edge = math.atan2(rig.width - 1 - cx, f)
    inner = cx + f * math.tan(max(edge + yaw, -edge))
    return max(lo, min(inner, hi - min_width)), hi, False


def scout_candidates_numpy(
    rng: np.random.Generator,
    k: np.ndarray,
    strip: tuple[float, float, bool],
    n: int,
    n_depths: int,
    rm: np.ndarray | None = None,
) -> np.ndarray:
    """Reference: (n·K, 3) candidates, scout i's K in rows i·K…i·K+K−1, for a ``strip``
    from :func:`entering_strip` (``k`` from :func:`~flylog.fly.operators.newcomer_constants`).
    A scout's disparities stay where its other projection is inside the image. ``rm``: a
    rolling shutter's motion per row (:func:`~flylog.geometry.rolling.row_motion`); a
    candidate seen at row v is then brought to the stamp by row v's motion."""
    lo, hi, margin, u_hi, v_lo, v_hi = (float(k[RIG_SIZE + j]) for j in range(6))
    fb, doffs = float(k[RIG_SIZE + 8]), float(k[RIG_SIZE + 9])
    c0, c1, in_right = strip
    w = rng.random((n, 2 + n_depths))
    c = c0 + (c1 - c0) * w[:, 0]
    v = v_lo + (v_hi - v_lo) * w[:, 1]
    room = (u_hi - c + doffs) if in_right else (c - margin + doffs)
    top = np.maximum(np.minimum(hi, room), lo)
    strata = (np.arange(n_depths)[None, :] + w[:, 2:]) / n_depths
    disparity = lo + (top - lo)[:, None] * strata
    z = fb / disparity
    u = (c[:, None] + (disparity - doffs)) if in_right else c[:, None]
    rows = np.broadcast_to(v[:, None], u.shape)
    out = _backproject_numpy(k, u, rows, z)
    if rm is not None:
        out = seen_at_stamp(out, rm, rows)
    return out.reshape(n * n_depths, 3)


def _backproject_numpy(
    k: np.ndarray, u: np.ndarray, v: np.ndarray, depth: np.ndarray
) -> np.ndarray:
    """:func:`flylog.geometry.kernels.backproject` over arrays (the same operations)."""
    f, cx, cy = float(k[FOCAL]), float(k[CX]), float(k[CY])
    r = [float(x) for x in k[ROWS : ROWS + 9]]
    a = (u - cx) * depth / f
    b = (v - cy) * depth / f
    return np.stack(
        [float(k[LEFT + j]) + (r[j] * a + r[3 + j] * b + r[6 + j] * depth) for j in range(3)],
        axis=-1,
    )


@numba.njit(cache=True, nogil=True)
def scout_candidates_into(
    rng, k, c0, c1, in_right, n_depths, rm, rolling, out
):  # pragma: no cover - compiled
    """Same candidates as :func:`scout_candidates_numpy` (n = len(out) // K), into ``out``;
    with ``rolling``, each brought from its row's time to the stamp by ``rm`` (per row)."""
    lo, hi, margin = k[RIG_SIZE], k[RIG_SIZE + 1], k[RIG_SIZE + 2]
    u_hi, v_lo, v_hi = k[RIG_SIZE + 3], k[RIG_SIZE + 4], k[RIG_SIZE + 5]
    fb, doffs = k[RIG_SIZE + 8], k[RIG_SIZE + 9]
    for i in range(out.shape[0] // n_depths):
        c = c0 + (c1 - c0) * rng.random()
        v = v_lo + (v_hi - v_lo) * rng.random()
        top = max(min(hi, (u_hi - c + doffs) if in_right else (c - margin + doffs)), lo)
        for j in range(n_depths):
            disparity = lo + (top - lo) * ((j + rng.random()) / n_depths)
            z = fb / disparity
            u = c + (disparity - doffs) if in_right else c
            r = i * n_depths + j
            x, y, out[r, 2] = backproject(k, u, v, z)
            if rolling:
                x, y = seen_at_stamp_kernel(rm, v, x, y)
            out[r, 0], out[r, 1] = x, y


def best_candidates_numpy(candidates: np.ndarray, fitness: np.ndarray, n_depths: int) -> np.ndarray:
    """Reference: (n, 3) each scout's fittest candidate (the first of equals)."""
    n = len(fitness) // n_depths
    best = fitness.reshape(n, n_depths).argmax(axis=1)
    return candidates.reshape(n, n_depths, 3)[np.arange(n), best]


@numba.njit(cache=True, nogil=True)
def best_candidates_into(candidates, fitness, n_depths, out):  # pragma: no cover - compiled
    """Same flies as :func:`best_candidates_numpy`, into ``out`` (n, 3)."""
    for i in range(out.shape[0]):
        best = i * n_depths
        for r in range(best + 1, best + n_depths):
            if fitness[r] > fitness[best]:
                best = r
        for j in range(3):
            out[i, j] = candidates[best, j]


@numba.njit(cache=True, nogil=True)
def scouts_into(rng, sc, n_scouts, im, measure, out):  # pragma: no cover - compiled
    """``n_scouts`` scouts in one call (numba types the Generator once), with the strip,
    constants and scratch of ``sc`` (:class:`~flylog.fly.bundles.Scouting`): candidates
    (:func:`scout_candidates_into`), their fitness on the pair ``im`` by ``measure``
    (serial: a few hundred flies), the best of each scout into ``out`` (n_scouts, 3)."""
    r = n_scouts * sc.n_depths
    candidates = sc.candidates[:r]
    fitness = sc.candidate_fitness[:r]
    scout_candidates_into(
        rng, sc.k, sc.c0, sc.c1, sc.in_right, sc.n_depths, im.row_motion, im.rolling, candidates
    )
    fitness_serial(im, measure, candidates, sc.candidate_index[:r], fitness)
    best_candidates_into(candidates, fitness, sc.n_depths, out)


class Scouting:
    """The engine's scouts: remembers the odometry's yaw per image interval, and places the
    scouts of one generation (:meth:`place`)."""

    def __init__(self, config: EngineConfig, rig: StereoRig, margin: int) -> None:
        self._on = config.scouting and config.scout_fraction > 0
        self._fraction = config.scout_fraction
        self._depths = config.scout_candidates
        self._min_shift = config.scout_min_shift
        self.rig = rig
        self._margin = margin
        self._window, self._guard = config.window, float(config.guard)
        self._gradient = config.gradient
        self._similarity = config.similarity
        self._subpixel = config.subpixel
        self._k = newcomer_constants(rig, config.d_min, config.d_max, margin)
        self._yaw = 0.0  # since the newest images
        self._frames = np.zeros(config.scout_strip_frames)  # yaw of the last image intervals
        self._strip = (0.0, -1.0, False)  # entering_strip(); empty while not turning enough
        self._scratch = (np.empty((0, 3)), np.empty(0, dtype=np.int64), np.empty(0))  # bundle()

    @property
    def strip(self) -> tuple[float, float, bool]:
        """Where scouts go now: :func:`entering_strip` (c1 < c0: nowhere)."""
        return self._strip

    def turned(self, yaw: float) -> None:
        """The robot turned by ``yaw`` rad (an odometry increment's theta)."""
        self._yaw += yaw

    def new_images(self) -> None:
        """New images arrived: the yaw since the last ones is one more image interval."""
        self._frames[1:] = self._frames[:-1]  # np.roll's result, in place (5× faster)
        self._frames[0], self._yaw = self._yaw, 0.0
        yaw = float(self._frames.sum())
        # the image moves fastest at the edge: f·sec²(half fov) px per rad
        edge_px = abs(yaw) * self.rig.focal_px / math.cos(self.rig.half_fov) ** 2
        if not self._on or edge_px < self._min_shift * len(self._frames):
            self._strip = (0.0, -1.0, False)
        else:
            self._strip = entering_strip(self.rig, yaw, self._margin)

    def count(self, n_immigrants: int, n_sonar: int) -> int:
        """How many of ``n_immigrants`` (``n_sonar`` of them from the sonar) scout now: the
        configured share of the uniform ones (the rest keep exploring the whole image);
        none while not turning."""
        if self._strip[1] < self._strip[0]:
            return 0
        return round(self._fraction * (n_immigrants - n_sonar))

    def bundle(self, n_immigrants: int) -> ScoutBundle:
        """What :func:`~flylog.fly.generation.generation_kernel` needs to place this
        generation's scouts as :meth:`place` does (:class:`~flylog.fly.bundles.Scouting`):
        the scouts' share of the uniform immigrants, 0 while not turning; c0, c1, in_right of
        :attr:`strip`; K; the constants; candidates, their index and fitness: scratch for up
        to ``n_immigrants`` scouts."""
        c0, c1, in_right = self._strip
        if len(self._scratch[0]) < n_immigrants * self._depths:
            size = n_immigrants * self._depths
            self._scratch = (np.empty((size, 3)), np.arange(size, dtype=np.int64), np.empty(size))
        candidates, index, fitness = self._scratch
        return ScoutBundle(
            fraction=float(self._fraction if c1 >= c0 else 0.0),
            c0=float(c0),
            c1=float(c1),
            in_right=bool(in_right),
            n_depths=int(self._depths),
            k=self._k,
            candidates=candidates,
            candidate_index=index,
            candidate_fitness=fitness,
        )

    def place(
        self,
        rng: np.random.Generator,
        xyz: np.ndarray,
        n_immigrants: int,
        n_sonar: int,
        left: np.ndarray,
        right: np.ndarray,
        *,
        readout: Pose2D = STILL,
    ) -> int:
        """The numpy backend's scouts: move the last :meth:`count` flies of ``xyz`` (uniform
        immigrants, after the sonar ones) to scouts' places; returns the fitness evaluations
        made, K per scout. ``left``, ``right``: (H, W, C) uint8 planes of the newest images,
        ``readout`` their rolling shutter's motion.
        The compiled backend places them in its generation (:func:`scouts_into`)."""
        n = self.count(n_immigrants, n_sonar)
        if n == 0:
            return 0
        k = self._depths
        rm = None if is_still(readout) else row_motion(readout, self.rig.height)
        candidates = scout_candidates_numpy(rng, self._k, self._strip, n, k, rm)
        fitness = fitness_numpy(
            left,
            right,
            candidates,
            self.rig,
            self._window,
            self._guard,
            gradient=self._gradient,
            similarity=self._similarity,
            subpixel=self._subpixel,
            readout=readout,
        )
        xyz[len(xyz) - n :] = best_candidates_numpy(candidates, fitness, k)
        return n * k
