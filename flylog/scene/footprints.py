"""Obstacle footprints as flat arrays: 2-D ray intersection and distance queries.

Every obstacle is a vertical extrusion of its footprint from z = 0 to its height. A box or a
wall is an oriented rectangle (centre, yaw, half sizes), a cylinder a disc. The renderer, the
sonar and the metrics all work on :class:`Footprints`, compiled once per scene.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from flylog.scene.spec import ObstacleConfig, ObstacleKind

RECT = 0
DISC = 1
# low_texture surfaces keep this fraction of their configured contrast.
LOW_TEXTURE_CONTRAST = 0.03


@dataclass(frozen=True)
class Footprints:
    """Structure of arrays, one entry per obstacle (index = obstacle id in rendered ``ids``)."""

    kind: np.ndarray  # (n,) int64: RECT or DISC
    cx: np.ndarray  # (n,) centre x (world, m)
    cy: np.ndarray
    cos: np.ndarray  # (n,) cos, sin of the rectangle's yaw (1, 0 for discs)
    sin: np.ndarray
    hx: np.ndarray  # (n,) half length along yaw; the radius for discs
    hy: np.ndarray  # (n,) half width; the radius for discs
    height: np.ndarray  # (n,)
    color: np.ndarray  # (n, 3) base colour in [0, 1]
    feature_size: np.ndarray  # (n,) m
    contrast: np.ndarray  # (n,) effective (low_texture already applied)
    sonar_visible: np.ndarray  # (n,) bool

    def __len__(self) -> int:
        return int(self.kind.shape[0])

    def bounding_radius(self) -> np.ndarray:
        """(n,) radius of a disc around each centre that holds the footprint."""
        return np.hypot(self.hx, self.hy) * (self.kind == RECT) + self.hx * (self.kind == DISC)


def compile_footprints(obstacles: Sequence[ObstacleConfig]) -> Footprints:
    """Flatten obstacle configs into :class:`Footprints`."""
    rows = []
    for ob in obstacles:
        if ob.kind is ObstacleKind.BOX:
            assert ob.center is not None and ob.size is not None
            yaw = math.radians(ob.yaw_deg)
            geo = (RECT, *ob.center, yaw, ob.size[0] / 2.0, ob.size[1] / 2.0)
        elif ob.kind is ObstacleKind.CYLINDER:
            assert ob.center is not None and ob.radius is not None
            geo = (DISC, *ob.center, 0.0, ob.radius, ob.radius)
        else:
            assert ob.start is not None and ob.end is not None
            (x0, y0), (x1, y1) = ob.start, ob.end
            yaw = math.atan2(y1 - y0, x1 - x0)
            # End caps of half the thickness so that walls meeting at a corner close it.
            half_len = math.hypot(x1 - x0, y1 - y0) / 2.0 + ob.thickness / 2.0
            geo = (RECT, (x0 + x1) / 2.0, (y0 + y1) / 2.0, yaw, half_len, ob.thickness / 2.0)
        contrast = ob.texture.contrast * (LOW_TEXTURE_CONTRAST if ob.low_texture else 1.0)
        rows.append((geo, ob.height, ob.texture, contrast, not ob.sonar_absorbing))
    n = len(rows)
    table = np.array([r[0] for r in rows], dtype=float).reshape(n, 6)
    return Footprints(
        kind=table[:, 0].astype(np.int64),
        cx=table[:, 1].copy(),
        cy=table[:, 2].copy(),
        cos=np.cos(table[:, 3]),
        sin=np.sin(table[:, 3]),
        hx=table[:, 4].copy(),
        hy=table[:, 5].copy(),
        height=np.array([r[1] for r in rows], dtype=float),
        color=np.array([r[2].color for r in rows], dtype=float).reshape(n, 3),
        feature_size=np.array([r[2].feature_size for r in rows], dtype=float),
        contrast=np.array([r[3] for r in rows], dtype=float),
        sonar_visible=np.array([r[4] for r in rows], dtype=bool),
    )


def distance_to_footprints(fp: Footprints, xy: np.ndarray) -> np.ndarray:
    """(N,) 2-D distance from points (N, 2) to the nearest footprint; 0 inside one; inf if
    there are no obstacles."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    best = np.full(xy.shape[0], np.inf)
    for k in range(len(fp)):
        dx, dy = xy[:, 0] - fp.cx[k], xy[:, 1] - fp.cy[k]
        if fp.kind[k] == DISC:
            d = np.maximum(np.hypot(dx, dy) - fp.hx[k], 0.0)
        else:
            lx = np.abs(fp.cos[k] * dx + fp.sin[k] * dy) - fp.hx[k]
            ly = np.abs(-fp.sin[k] * dx + fp.cos[k] * dy) - fp.hy[k]
            d = np.hypot(np.maximum(lx, 0.0), np.maximum(ly, 0.0))
        best = np.minimum(best, d)
    return best


def closest_points(fp: Footprints, x: float, y: float) -> np.ndarray:
    """(n, 2): the point of each footprint nearest to (x, y) (the point itself if inside)."""
    dx, dy = x - fp.cx, y - fp.cy
    lx = np.clip(fp.cos * dx + fp.sin * dy, -fp.hx, fp.hx)
    ly = np.clip(-fp.sin * dx + fp.cos * dy, -fp.hy, fp.hy)
    rect = np.stack([fp.cx + fp.cos * lx - fp.sin * ly, fp.cy + fp.sin * lx + fp.cos * ly], 1)
    r = np.hypot(dx, dy)
    scale = np.minimum(1.0, fp.hx / np.where(r > 0, r, 1.0))
    disc = np.stack([fp.cx + dx * scale, fp.cy + dy * scale], axis=1)
    return np.where((fp.kind == DISC)[:, None], disc, rect)


def ray_hits_numpy(
    fp: Footprints,
    ox: float | np.ndarray,
    oy: float | np.ndarray,
    dx: float | np.ndarray,
    dy: float | np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The 2-D ray O + t·D against every footprint: (t_in, t_out, nx, ny), each (n,).

    t_in > t_out (both inf) where the ray misses; (nx, ny) is the outward normal at entry.
    Plain-numpy reference of :func:`flylog.scene.ray_kernel.ray_hit`.
    """
    px, py = ox - fp.cx, oy - fp.cy
    # Rectangles: slabs in the footprint's own frame.
    lpx, lpy = fp.cos * px + fp.sin * py, -fp.sin * px + fp.cos * py
    ldx, ldy = fp.cos * dx + fp.sin * dy, -fp.sin * dx + fp.cos * dy
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ax = np.where(ldx != 0.0, ldx, 1e-300)
        ay = np.where(ldy != 0.0, ldy, 1e-300)
        tx1, tx2 = (-fp.hx - lpx) / ax, (fp.hx - lpx) / ax
        ty1, ty2 = (-fp.hy - lpy) / ay, (fp.hy - lpy) / ay
    txn, txf = np.minimum(tx1, tx2), np.maximum(tx1, tx2)
    tyn, tyf = np.minimum(ty1, ty2), np.maximum(ty1, ty2)
    rect_in, rect_out = np.maximum(txn, tyn), np.minimum(txf, tyf)
    enter_x = txn >= tyn
    lnx = np.where(enter_x, -np.sign(ldx), 0.0)
    lny = np.where(enter_x, 0.0, -np.sign(ldy))
    rect_nx, rect_ny = fp.cos * lnx - fp.sin * lny, fp.sin * lnx + fp.cos * lny
    # Discs: the quadratic |P + tD|² = r².
    a = dx * dx + dy * dy
    b = px * dx + py * dy
    c = px * px + py * py - fp.hx * fp.hx
    disc = b * b - a * c
    root = np.sqrt(np.maximum(disc, 0.0))
    d_in, d_out = (-b - root) / a, (-b + root) / a
    ex, ey = px + d_in * dx, py + d_in * dy
    is_disc = fp.kind == DISC
    t_in = np.where(is_disc, d_in, rect_in)
    t_out = np.where(is_disc, d_out, rect_out)
    nx = np.where(is_disc, ex / fp.hx, rect_nx)
    ny = np.where(is_disc, ey / fp.hx, rect_ny)
    miss = (t_out < t_in) | (t_out <= 0.0) | (is_disc & (disc < 0.0))
    t_in = np.where(miss, np.inf, t_in)
    t_out = np.where(miss, -np.inf, t_out)
    return t_in, t_out, nx, ny
